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


def read_ply(path):
    """Points (x, y, z) and triangles of a PLY file, as VTK's reader gives them."""
    reader = vtk.vtkPLYReader()
    reader.SetFileName(str(path))
    reader.Update()
    mesh = reader.GetOutput()
    points = numpy_support.vtk_to_numpy(mesh.GetPoints().GetData())
    cells = numpy_support.vtk_to_numpy(mesh.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    return points, cells


@pytest.mark.parametrize("smooth", [0, 20])
def test_label_surfaces_of_the_atlas_array_equal_extract_of_its_file(tmp_path, smooth):
    """label_surfaces() on the atlas as VTK's NIfTI reader loads it gives, label by label, the
    vertices and triangles that extract() writes for the file (voxel space), in scikit-image's index
    order, smoothed or not; its adjacency is the voxel faces' brute-force count."""
    isoslab = pytest.importorskip("isoslab")
    path = os.path.join(TEMPLATES, "aal.nii.gz")
    if not os.path.exists(path):
        pytest.skip(f"{path} is absent (Debian's mricron-data)")
    labels, spacing = read_labels(path)
    surfaces, adjacency = isoslab.label_surfaces(labels.astype(np.int16), spacing=spacing[::-1], threads=2,
                                                 smooth=smooth)
    report = isoslab.extract(path, tmp_path / "{label}.ply", labels="all", space="voxel", smooth=smooth,
                             progress=False)
    assert sorted(surfaces) == [e["value"] for e in report["labels"]]
    assert len(surfaces) == 116
    for entry in report["labels"]:
        verts, faces = surfaces[entry["value"]]
        points, cells = read_ply(entry["path"])
        assert verts.dtype == np.float32 and faces.dtype == np.int32
        # (plane, row, column) times spacing back to voxel (x, y, z).
        assert np.array_equal(verts[:, ::-1] / np.asarray(spacing, np.float32), points), entry["value"]
        assert np.array_equal(faces, cells), entry["value"]
    expected = brute_force_interfaces(labels, spacing)
    assert adjacency.keys() == expected.keys()
    if not smooth:  # smoothed interfaces have their own areas
        assert all(abs(adjacency[k] - expected[k]) <= 1e-6 * expected[k] for k in expected)


def test_label_surfaces_are_closed_shared_and_oriented_as_scikit_image():
    """Two boxes that touch, a voxel apart from them, on an anisotropic grid: each surface is
    closed, encloses its voxels' volume, winds as skimage's marching_cubes winds the label's mask,
    and the interface is the same triangles in both surfaces, reversed."""
    isoslab = pytest.importorskip("isoslab")
    measure = pytest.importorskip("skimage.measure")
    a = np.zeros((12, 14, 16), np.uint8)
    a[2:9, 3:11, 2:8] = 4
    a[2:9, 3:11, 8:13] = 200
    a[10, 12, 14] = 9
    spacing = (2.0, 0.5, 1.0)
    surfaces, adjacency = isoslab.label_surfaces(a, spacing=spacing)
    assert sorted(surfaces) == [4, 9, 200]
    assert adjacency == {(4, 200): 7 * 8 * 2.0 * 0.5}

    def signed_volume(v, f):
        v = v.astype(np.float64)
        return np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6

    for label, (verts, faces) in surfaces.items():
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        forward = {tuple(e) for e in edges.tolist()}
        assert len(forward) == len(edges)  # no edge twice the same way
        assert all((b, c) in forward for c, b in forward)  # and each once the other way: closed
        voxels = np.count_nonzero(a == label)
        assert abs(abs(signed_volume(verts, faces)) - voxels * 2.0 * 0.5 * 1.0) < 1e-6 * voxels
        mask_verts, mask_faces, _, _ = measure.marching_cubes((a == label).astype(np.float32), 0.5, spacing=spacing)
        assert np.sign(signed_volume(verts, faces)) == np.sign(signed_volume(mask_verts, mask_faces))
    # The interface: triangles of 4 whose corners all lie on the plane x = 8 (column 7.5 .. 8)
    # are those of 200 reversed, by position.
    def interface(label):
        verts, faces = surfaces[label]
        on = np.all(verts[faces][:, :, 2] == 7.5, axis=1)
        return {tuple(map(tuple, verts[f].tolist())) for f in faces[on]}

    mine = interface(4)
    theirs = {(t[0], t[2], t[1]) for t in interface(200)}
    assert len(mine) == 7 * 8 * 2 and mine == theirs


def test_label_surfaces_refuses_what_it_cannot_mesh():
    isoslab = pytest.importorskip("isoslab")
    with pytest.raises(ValueError, match="should hold integers"):
        isoslab.label_surfaces(np.zeros((4, 4, 4), np.float32))
    with pytest.raises(ValueError, match="3D"):
        isoslab.label_surfaces(np.zeros((4, 4), np.int32))
    with pytest.raises(isoslab.Error, match="decimate must be above 0 and at most 1"):
        isoslab.label_surfaces(np.ones((4, 4, 4), np.int32), decimate=1.5)
    # Counts are whole numbers in range (a float was truncated; 2**40 failed in pybind's cast), the
    # spacing three finite numbers (NaN was named by isoslab's axis, not the array's).
    ones = np.ones((4, 4, 4), np.int32)
    for name, value, error, message in [("threads", 1.5, TypeError, "threads must be a whole number"),
                                        ("smooth", True, TypeError, "smooth must be a whole number"),
                                        ("threads", 2**40, ValueError, "threads must be from 1 to 256"),
                                        ("threads", 0, ValueError, "threads must be from 1 to 256"),
                                        ("keep_largest", -1, ValueError, "keep_largest must be from 1 to"),
                                        ("spacing", (float("nan"), 1, 1), ValueError, "spacing must be three finite"),
                                        ("spacing", (1, 2), ValueError, "spacing must be three finite")]:
        with pytest.raises(error, match=message):
            isoslab.label_surfaces(ones, **{name: value})
    assert list(isoslab.label_surfaces(ones, threads=np.int64(2), spacing=(-1, 1, 2))[0]) == [1]
    # 2^24 + 1 is read (as a float) as 2^24: the two would be one label, so both are refused.
    big = np.zeros((4, 4, 4), np.int32)
    big[1, 1, 1], big[1, 1, 2] = 2**24 + 1, 2**24
    with pytest.raises(isoslab.Error, match=r"16777216 or more in magnitude \(read as 16777216\)"):
        isoslab.label_surfaces(big)
    big[1, 1, 1], big[1, 1, 2] = 2**24 - 1, -(2**24 - 1)
    assert sorted(isoslab.label_surfaces(big)[0]) == [-(2**24 - 1), 2**24 - 1]


def test_label_surfaces_decimated_stay_closed_and_touch_where_they_did():
    """Three labels of a ball (two halves and a core), smoothed and decimated to a fifth: every
    surface is closed, has fewer triangles, keeps its volume within 3%, and the labels that touched
    still touch, through triangles that both surfaces hold (reversed)."""
    isoslab = pytest.importorskip("isoslab")
    z, y, x = np.mgrid[:30, :30, :30] - 14.5
    r = np.sqrt(x * x + y * y + z * z)
    a = np.zeros((30, 30, 30), np.uint8)
    a[r < 13] = 1
    a[(r < 13) & (x > 0)] = 2
    a[r < 6] = 3
    plain, touching = isoslab.label_surfaces(a, smooth=20)
    surfaces, adjacency = isoslab.label_surfaces(a, smooth=20, decimate=0.2)
    assert adjacency.keys() == touching.keys() == {(1, 2), (1, 3), (2, 3)}

    def signed_volume(v, f):
        v = v.astype(np.float64)
        return np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6

    def triangles(label, reverse=False):
        verts, faces = surfaces[label]
        order = [0, 2, 1] if reverse else [0, 1, 2]
        return {tuple(map(tuple, verts[f[order]].tolist())) for f in faces}

    for label, (verts, faces) in surfaces.items():
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        forward = {tuple(e) for e in edges.tolist()}
        assert len(forward) == len(edges) and all((b, c) in forward for c, b in forward), label
        assert len(faces) < 0.4 * len(plain[label][1]), label
        before = signed_volume(*plain[label])
        assert abs(signed_volume(verts, faces) - before) < 0.03 * abs(before), label
    for a_, b_ in adjacency:
        assert triangles(a_) & triangles(b_, reverse=True), (a_, b_)


def reference_component_rules(labels, keep_largest=None, min_voxels=None):
    """Per-label component rules by brute force with SciPy: each label's 6-connected components
    (scipy.ndimage.label), their voxels and boundary faces (the outside counts as background),
    the rules (thresholds, then the N largest by faces, ties to the earlier first voxel), groups of
    touching dropped components, and the label each group takes: the one of the kept components
    and the background around it with the most shared faces (ties: the lower value). Returns the
    relabelled volume and per label (found, dropped)."""
    ndimage = pytest.importorskip("scipy.ndimage")
    comp = np.full(labels.shape, -1, dtype=np.int64)
    comp_label, first = [], []
    for value, box in enumerate(ndimage.find_objects(labels), start=1):  # labels from 1
        if box is None:
            continue
        parts, n = ndimage.label(labels[box] == value)
        for k in range(1, n + 1):
            where = parts == k
            comp[box][where] = len(comp_label)
            coords = np.argwhere(where)[0] + [s.start for s in box]
            first.append(np.ravel_multi_index(tuple(coords), labels.shape))
            comp_label.append(value)
    n = len(comp_label)
    comp_label = np.array(comp_label)
    voxels = np.bincount(comp[comp >= 0], minlength=n)
    faces = np.zeros(n, dtype=np.int64)
    background = np.zeros(n, dtype=np.int64)
    contacts = {}
    padded_l = np.pad(labels, 1)
    padded_c = np.pad(comp, 1, constant_values=-1)
    for axis in range(3):
        l = np.moveaxis(padded_l, axis, 0)
        c = np.moveaxis(padded_c, axis, 0)
        lo_l, hi_l, lo_c, hi_c = l[:-1].ravel(), l[1:].ravel(), c[:-1].ravel(), c[1:].ravel()
        differ = lo_l != hi_l
        for a, b, other in ((lo_c, hi_c, hi_l), (hi_c, lo_c, lo_l)):
            side = differ & (a >= 0)
            faces += np.bincount(a[side], minlength=n)
            background += np.bincount(a[side & (other == 0)], minlength=n)
        both = differ & (lo_c >= 0) & (hi_c >= 0)
        pairs = np.stack([np.minimum(lo_c[both], hi_c[both]), np.maximum(lo_c[both], hi_c[both])], axis=1)
        for (p, q), k in zip(*np.unique(pairs, axis=0, return_counts=True)):
            contacts[(int(p), int(q))] = contacts.get((int(p), int(q)), 0) + int(k)
    keep = np.ones(n, dtype=bool)
    if min_voxels is not None:
        keep &= voxels >= min_voxels
    if keep_largest is not None:
        for value in np.unique(comp_label):
            ids = [i for i in np.flatnonzero(comp_label == value) if keep[i]]
            ids.sort(key=lambda i: (-faces[i], first[i]))
            keep[ids[keep_largest:]] = False
    group = list(range(n))

    def find(i):
        while group[i] != i:
            group[i] = group[group[i]]
            i = group[i]
        return i

    for (p, q) in contacts:
        if not keep[p] and not keep[q]:
            group[max(find(p), find(q))] = min(find(p), find(q))
    around = {}
    for i in np.flatnonzero(~keep):
        around.setdefault(find(i), {}).setdefault(0, 0)
        around[find(i)][0] += background[i]
    for (p, q), k in contacts.items():
        if keep[p] != keep[q]:
            dropped, kept = (q, p) if keep[p] else (p, q)
            tally = around.setdefault(find(dropped), {})
            tally[int(comp_label[kept])] = tally.get(int(comp_label[kept]), 0) + k
    takes = {g: min(tally, key=lambda v: (-tally[v], v)) for g, tally in around.items()}
    out = labels.copy()
    target = np.array([comp_label[i] if keep[i] else takes[find(i)] for i in range(n)])
    inside = comp >= 0
    out[inside] = target[comp[inside]]
    stats = {int(v): (int(np.sum(comp_label == v)), int(np.sum((comp_label == v) & ~keep))) for v in np.unique(comp_label)}
    return out, stats


@pytest.mark.parametrize("rules", [{"keep_largest": 1}, {"min_voxels": 40}])
def test_atlas_component_rules_against_scipy(rules, tmp_path):
    """--keep-largest and --min-volume on the AAL atlas: each label's components found, dropped,
    and the relabelled volume (its voxel counts and every interface's area) as SciPy's brute force
    gives them; every surface closed and of the relabelled voxels' volume."""
    path = os.path.join(TEMPLATES, "aal.nii.gz")
    if not os.path.exists(path):
        pytest.skip(f"{path} is absent (Debian's mricron-data)")
    labels, spacing = read_labels(path)
    voxel = spacing[0] * spacing[1] * spacing[2]
    args = [path, "-o", str(tmp_path / "{label}.ply")]
    if "keep_largest" in rules:
        args += ["--keep-largest", str(rules["keep_largest"])]
    else:
        args += ["--min-volume", str(rules["min_voxels"] * voxel - 1e-6)]
    report = run(args, tmp_path)
    expected, stats = reference_component_rules(labels, **rules)
    dropped = sum(d for _, d in stats.values())
    assert dropped > 10  # the atlas has specks to drop
    assert report["component_filter"]["dropped"]["count"] == dropped
    values, counts = np.unique(expected[expected != 0], return_counts=True)
    assert [entry["value"] for entry in report["labels"]] == values.tolist()
    for entry, n in zip(report["labels"], counts):
        assert entry["voxels"] == n
        assert (entry["components"]["found"], entry["components"]["dropped"]) == stats[entry["value"]]
        assert entry["closed"] and entry["oriented"]
        assert entry["mesh_volume"] == pytest.approx(n * voxel, rel=1e-9)
    found = {tuple(i["labels"]): i["area"] for i in report["label_interfaces"]}
    wanted = brute_force_interfaces(expected, spacing)
    assert set(found) == set(wanted)
    for pair, area in wanted.items():
        assert found[pair] == pytest.approx(area, rel=1e-9)


def test_label_surfaces_with_component_rules_mesh_the_relabelled_array():
    """label_surfaces(keep_largest=, min_volume=) on noisy blobs equals label_surfaces of the array
    that SciPy's brute force relabels, label by label, vertex for vertex."""
    isoslab = pytest.importorskip("isoslab")
    ndimage = pytest.importorskip("scipy.ndimage")
    rng = np.random.default_rng(5)
    blobs = ndimage.gaussian_filter(rng.standard_normal((40, 36, 30)), 2.0)
    labels = np.digitize(blobs, [-0.05, 0.0, 0.05]).astype(np.int16)  # four labels, many specks
    for rules in ({"keep_largest": 1}, {"min_voxels": 20}):
        expected, stats = reference_component_rules(labels.astype(np.int64), **rules)
        assert sum(d for _, d in stats.values()) > 5
        kwargs = {"keep_largest": rules["keep_largest"]} if "keep_largest" in rules else \
            {"min_volume": rules["min_voxels"] * 0.5 ** 3 - 1e-9}
        got, got_adjacency = isoslab.label_surfaces(labels, spacing=(0.5, 0.5, 0.5), **kwargs)
        want, want_adjacency = isoslab.label_surfaces(expected.astype(np.int16), spacing=(0.5, 0.5, 0.5))
        assert sorted(got) == sorted(want)
        for label in want:
            np.testing.assert_array_equal(got[label][0], want[label][0])
            np.testing.assert_array_equal(got[label][1], want[label][1])
        assert got_adjacency == want_adjacency
