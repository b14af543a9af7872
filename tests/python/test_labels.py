"""Label maps (issue 35) against references isoslab did not write: the atlases of Debian's
mricron-data read by VTK's NIfTI reader, label adjacency and voxel counts by brute force in NumPy,
and the per-label STLs read back by VTK."""

import json
import os
import subprocess

import numpy as np
import pytest

PROGRAM = os.environ.get("ISOSLAB_PROGRAM", "isoslab")
TEMPLATES = "/usr/share/mricron/templates"
ATLASES = [
    ("aal.nii.gz", "aal.nii.txt"),
    ("HarvardOxford-cort-maxprob-thr0-1mm.nii.gz", None),
]

vtk = pytest.importorskip("vtk")
from vtk.util import numpy_support  # noqa: E402


def read_labels(path):
    """The label volume as VTK reads it, indexed [k, j, i], and its spacing."""
    reader = vtk.vtkNIFTIImageReader()
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    nx, ny, nz = image.GetDimensions()
    values = numpy_support.vtk_to_numpy(image.GetPointData().GetScalars()).reshape(nz, ny, nx)
    return values.astype(np.int64), image.GetSpacing()


def brute_force_interfaces(labels, spacing):
    """Area of the faces between each pair of different non-zero labels, by voxel faces."""
    areas = {}
    sx, sy, sz = spacing
    for axis, face in ((2, sy * sz), (1, sx * sz), (0, sx * sy)):
        a = np.moveaxis(labels, axis, 0)
        lo, hi = a[:-1].ravel(), a[1:].ravel()
        keep = (lo != hi) & (lo != 0) & (hi != 0)
        pairs = np.stack([np.minimum(lo[keep], hi[keep]), np.maximum(lo[keep], hi[keep])], axis=1)
        unique, counts = np.unique(pairs, axis=0, return_counts=True)
        for (p, q), n in zip(unique, counts):
            areas[(int(p), int(q))] = areas.get((int(p), int(q)), 0.0) + n * face
    return areas


def run(args, tmp_path):
    report = tmp_path / "report.json"
    result = subprocess.run([PROGRAM, "extract", *args, "--report", str(report), "-q"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return json.loads(report.read_text())


@pytest.mark.parametrize("atlas,table", ATLASES)
def test_atlas_adjacency_counts_and_volumes(atlas, table, tmp_path):
    path = os.path.join(TEMPLATES, atlas)
    if not os.path.exists(path):
        pytest.skip(f"{path} is absent (Debian's mricron-data)")
    args = [path, "-o", str(tmp_path / "{label}.stl")]
    if table:
        args += ["--label-table", os.path.join(TEMPLATES, table)]
    report = run(args, tmp_path)
    labels, spacing = read_labels(path)
    voxel = spacing[0] * spacing[1] * spacing[2]

    # The input says it holds labels (NIFTI_INTENT_LABEL), so no --labels was needed.
    values, counts = np.unique(labels[labels != 0], return_counts=True)
    assert [entry["value"] for entry in report["labels"]] == values.tolist()
    for entry, n in zip(report["labels"], counts):
        assert entry["voxels"] == n
        assert entry["closed"] and entry["oriented"]
        # Voxel faces: the mesh encloses exactly the voxels' volume (well within the 2% asked).
        assert entry["mesh_volume"] == pytest.approx(n * voxel, rel=1e-9)
    smallest = min(report["labels"], key=lambda e: e["voxels"])
    assert smallest["mesh_volume"] == pytest.approx(smallest["voxels"] * voxel, rel=1e-9)

    # The label adjacency and each interface's area, against the voxels.
    expected = brute_force_interfaces(labels, spacing)
    found = {tuple(i["labels"]): i["area"] for i in report["label_interfaces"]}
    assert set(found) == set(expected)
    for pair, area in expected.items():
        assert found[pair] == pytest.approx(area, rel=1e-9)

    if table:
        names = {int(line.split()[0]): line.split()[1] for line in open(os.path.join(TEMPLATES, table)) if line.strip()}
        assert all(entry["name"] == names[entry["value"]] for entry in report["labels"])

    # Every per-label STL, read by VTK: the report's triangles, and VTK's own closedness check.
    for entry in report["labels"][:: max(1, len(report["labels"]) // 12)]:
        reader = vtk.vtkSTLReader()
        reader.SetFileName(entry["path"])
        reader.Update()
        mesh = reader.GetOutput()
        assert mesh.GetNumberOfCells() == entry["triangles"]
        edges = vtk.vtkFeatureEdges()
        edges.SetInputData(mesh)
        edges.BoundaryEdgesOn()
        edges.NonManifoldEdgesOff()
        edges.FeatureEdgesOff()
        edges.ManifoldEdgesOff()
        edges.Update()
        assert edges.GetOutput().GetNumberOfCells() == 0, entry["name"]


def test_selection_by_name_range_and_value(tmp_path):
    path = os.path.join(TEMPLATES, "aal.nii.gz")
    if not os.path.exists(path):
        pytest.skip(f"{path} is absent (Debian's mricron-data)")
    table = os.path.join(TEMPLATES, "aal.nii.txt")
    report = run([path, "--label-table", table, "--labels", "Hippocampus_L,3-5,90", "-o", str(tmp_path / "{name}.ply")],
                 tmp_path)
    assert [e["value"] for e in report["labels"]] == [3, 4, 5, 37, 90]
    assert [e["name"] for e in report["labels"]][3] == "Hippocampus_L"
    assert all(os.path.exists(e["path"]) and e["path"].endswith(e["name"] + ".ply") for e in report["labels"])


def test_extract_in_process_takes_labels_tables_and_iso_lists(tmp_path):
    """isoslab.extract() runs label maps and iso lists as the program does: the same files and the
    same per-label report, for the selection given as a list."""
    isoslab = pytest.importorskip("isoslab")
    path = os.path.join(TEMPLATES, "aal.nii.gz")
    if not os.path.exists(path):
        pytest.skip(f"{path} is absent (Debian's mricron-data)")
    table = os.path.join(TEMPLATES, "aal.nii.txt")
    program = run([path, "--label-table", table, "--labels", "Hippocampus_L,3-5", "-o", str(tmp_path / "p{label}.ply")],
                  tmp_path)
    report = isoslab.extract(path, tmp_path / "x{label}.ply", labels=["Hippocampus_L", "3-5"], label_table=table,
                             progress=False)
    assert [e["value"] for e in report["labels"]] == [e["value"] for e in program["labels"]] == [3, 4, 5, 37]
    for mine, theirs in zip(report["labels"], program["labels"]):
        assert mine["name"] == theirs["name"] and mine["voxels"] == theirs["voxels"]
        assert open(mine["path"], "rb").read() == open(theirs["path"], "rb").read()
    assert report["label_interfaces"] == program["label_interfaces"]
    # Two iso values in one pass: one surface each, as two runs of one value give.
    both = isoslab.extract("phantom:nested?n=24", tmp_path / "{iso}.ply", iso=[0.5, 1.5], progress=False)
    assert [e["iso"] for e in both["labels"]] == [0.5, 1.5]
    for value, entry in zip((0.5, 1.5), both["labels"]):
        single = isoslab.extract("phantom:nested?n=24", tmp_path / "single.ply", iso=value, progress=False)
        assert single["triangles"] == entry["triangles"]
