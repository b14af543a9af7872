"""The Python module (issue 21), against scikit-image 0.19, the isoslab program and NumPy.

Run by ctest (tests/CMakeLists.txt) as /usr/bin/python3 -m pytest, with PYTHONPATH set to the
build tree's python/ folder and ISOSLAB_PROGRAM to the program.
"""
import os
import subprocess
import threading
import time

import numpy as np
import pytest
from scipy.spatial import cKDTree
from skimage import measure

import isoslab
from fields import same_vertex_sets, smooth_noise

PROGRAM = os.environ.get("ISOSLAB_PROGRAM", "isoslab")
BRAIN = "/usr/share/mricron/templates/ch2better.nii.gz"


def sphere_field(shape=(20, 22, 24), centre=(9.3, 10.1, 11.7)):
    z, y, x = np.mgrid[0:shape[0], 0:shape[1], 0:shape[2]]
    return -np.sqrt((z - centre[0]) ** 2 + (y - centre[1]) ** 2 + (x - centre[2]) ** 2).astype(np.float32)


def signed_volume(verts, faces):
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)


def test_version():
    assert isoslab.__version__ == subprocess.run([PROGRAM, "--version"], capture_output=True, text=True,
                                                 check=True).stdout.split()[-1]


# scikit-image's "lorensen" is the classic Marching Cubes with welded vertices, as isoslab's mc:
# the vertices are the same points (isoslab interpolates in double, scikit-image in float: they
# agree to about 1e-6). The triangle counts are equal here; they may differ only on a cell that
# is ambiguous, where the two case tables may choose different (equally valid) triangulations.
@pytest.mark.parametrize("name", ["sphere", "noise0", "noise1", "brain"])
def test_mc_vertices_equal_scikit_image_lorensen(name, capsys):
    if name == "sphere":
        volume, level, spacing = sphere_field(), -6.0, (1.0, 1.0, 1.0)
    elif name == "brain":
        if not os.path.exists(BRAIN):
            pytest.skip(f"{BRAIN} is absent (Debian: mricron-data)")
        import gzip
        data = gzip.open(BRAIN).read()
        dims = np.frombuffer(data, "<i2", 3, 42)
        offset = int(np.frombuffer(data, "<f4", 1, 108)[0])
        volume = np.frombuffer(data, np.uint8, int(np.prod(dims)), offset).reshape(dims[::-1])
        level, spacing = 50.0, (1.0, 1.0, 1.0)
    else:
        volume = smooth_noise((30, 26, 28), int(name[-1]))
        level, spacing = 0.05, (1.0, 2.0, 0.5)
    verts, faces, normals, values = isoslab.marching_cubes(volume, level, spacing=spacing, method="lorensen")
    sv, sf, sn, svals = measure.marching_cubes(volume, level, spacing=spacing, method="lorensen")
    with capsys.disabled():
        print(f"\n{name}: isoslab {len(verts)} vertices, {len(faces)} triangles; "
              f"scikit-image lorensen {len(sv)} vertices, {len(sf)} triangles")
    assert same_vertex_sets(verts, sv.astype(np.float32))
    assert len(faces) == len(sf)
    # The same orientation (sign of the enclosed volume) and the same values per vertex.
    assert np.sign(signed_volume(verts, faces)) == np.sign(signed_volume(sv, sf))
    _, match = cKDTree(sv).query(verts)
    np.testing.assert_allclose(values, svals[match], rtol=1e-6, atol=1e-6)
    # Normals: scikit-image's are another estimate of the gradient (it sums the cells' corner
    # gradients), so they only point the same way on the whole; the exact reference is below.
    dots = np.einsum("ij,ij->i", normals, sn[match])
    assert (dots > 0).mean() > 0.97
    assert_normals_are_the_interpolated_gradient(volume, verts / np.float32(spacing), normals)


def assert_normals_are_the_interpolated_gradient(volume, lattice, normals):
    """Brute force: each vertex on a lattice edge (one coordinate between two points), its unit
    normal is minus the central-difference gradient (np.gradient: one-sided at the faces) of the
    two ends, interpolated at the vertex; in index space, as scikit-image's."""
    gradient = np.stack(np.gradient(volume.astype(np.float64)), axis=-1)
    lattice = lattice.astype(np.float64)
    frac = np.abs(lattice - np.round(lattice)) > 1e-6
    on_edge = frac.sum(axis=1) == 1  # the others lie on a lattice point
    p, n = lattice[on_edge], normals[on_edge]
    rows = np.arange(len(p))
    axis = np.argmax(frac[on_edge], axis=1)
    a = np.round(p).astype(np.int64)
    a[rows, axis] = np.floor(p[rows, axis]).astype(np.int64)
    b = a.copy()
    b[rows, axis] += 1
    t = (p[rows, axis] - a[rows, axis])[:, None]
    g = (1 - t) * gradient[a[:, 0], a[:, 1], a[:, 2]] + t * gradient[b[:, 0], b[:, 1], b[:, 2]]
    np.testing.assert_allclose(n, -g / np.linalg.norm(g, axis=1)[:, None], atol=2e-4)
    checked = len(p)
    assert checked > 0.9 * len(lattice)


def test_gradient_direction_reverses_the_faces_as_scikit_image():
    volume = sphere_field()
    for direction in ("descent", "ascent"):
        verts, faces, normals, _ = isoslab.marching_cubes(volume, -6.0, gradient_direction=direction)
        sv, sf, _, _ = measure.marching_cubes(volume, -6.0, gradient_direction=direction, method="lorensen")
        assert np.sign(signed_volume(verts, faces)) == np.sign(signed_volume(sv, sf)) != 0
    # The normals point out of the bright sphere (from high to low values) either way.
    centre = np.array([9.3, 10.1, 11.7])
    assert (np.einsum("ij,ij->i", normals, verts - centre) > 0).all()


def test_allow_degenerate_false_drops_triangles_with_repeated_points():
    # Values equal to the level put vertices on lattice points: triangles there may collapse.
    volume = np.zeros((6, 6, 6), np.float32)
    volume[2:4, 2:4, 2:4] = 1
    volume[3, 3, 3] = 0.5
    verts, faces, _, _ = isoslab.marching_cubes(volume, 0.5)
    kept_verts, kept_faces, _, _ = isoslab.marching_cubes(volume, 0.5, allow_degenerate=False)
    a, b, c = (kept_verts[kept_faces[:, k]] for k in range(3))
    assert not ((a == b).all(1) | (a == c).all(1) | (b == c).all(1)).any()
    a, b, c = (verts[faces[:, k]] for k in range(3))
    degenerate = ((a == b).all(1) | (a == c).all(1) | (b == c).all(1)).sum()
    assert len(kept_faces) == len(faces) - degenerate
    assert set(np.unique(kept_faces)) == set(range(len(kept_verts)))


def phantom(tmp_path, spec="phantom:head?n=24,22,20&noise=60"):
    """A phantom as a raw i16 file and as the array it holds (z, y, x)."""
    raw = tmp_path / "phantom.raw"
    subprocess.run([PROGRAM, "phantom", spec, "-o", str(raw)], check=True, capture_output=True)
    return raw, np.fromfile(raw, "<i2").reshape(20, 22, 24)


def read_ply(path):
    """Vertices (x, y, z) and faces of a binary PLY written by isoslab without normals."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    nv = int(next(l for l in header if l.startswith("element vertex")).split()[-1])
    nf = int(next(l for l in header if l.startswith("element face")).split()[-1])
    verts = np.frombuffer(data, "<f4", 3 * nv, end).reshape(nv, 3)
    faces = np.frombuffer(data, np.dtype([("n", "u1"), ("i", "<u4", 3)]), nf, end + 12 * nv)
    assert (faces["n"] == 3).all()
    return verts, faces["i"].astype(np.int64)


@pytest.mark.parametrize("method", ["mc", "mt5", "mt6", "bcc12", "mt24", "mc33"])
def test_round_trip_equals_the_program_on_the_same_volume(tmp_path, method):
    raw, volume = phantom(tmp_path)
    out = tmp_path / f"{method}.ply"
    subprocess.run([PROGRAM, "extract", str(raw), "--raw-dims", "24,22,20", "--raw-type", "i16", "--iso", "0",
                    "--method", method, "-q", "-o", str(out)], check=True, capture_output=True)
    expected_verts, expected_faces = read_ply(out)
    verts, faces, _, _ = isoslab.marching_cubes(volume, 0.0, method=method)
    np.testing.assert_array_equal(verts[:, ::-1], expected_verts)
    np.testing.assert_array_equal(faces, expected_faces)
    # Two threads, an int16 array read in place of float32: the same.
    again = isoslab.marching_cubes(volume, 0.0, method=method, threads=2)
    np.testing.assert_array_equal(again[0], verts)
    np.testing.assert_array_equal(again[1], faces)


def test_any_dtype_and_strides_give_the_float32_result(tmp_path):
    _, volume = phantom(tmp_path)
    reference = isoslab.marching_cubes(np.ascontiguousarray(volume, np.float32), 10.0)
    big = np.zeros((40, 44, 48), np.float64)
    big[::2, ::2, ::2] = volume
    for variant in (volume, volume.astype(np.float64), np.asfortranarray(volume), big[::2, ::2, ::2],
                    volume.astype(np.int32), volume.astype(">i2")):
        if variant.dtype.byteorder == ">":
            with pytest.raises(ValueError, match="byte order"):
                isoslab.marching_cubes(variant, 10.0)
            continue
        result = isoslab.marching_cubes(variant, 10.0)
        for got, want in zip(result, reference):
            np.testing.assert_array_equal(got, want)


def test_nan_voxels_give_the_same_result_in_place_and_converted():
    # NaN voxels (outside a scanner's field of view, say) count as outside; the values of the
    # vertices beside them come from the in-place float32 path and from the converting path
    # alike (they once differed: the in-place path's min and max kept or dropped a NaN by its
    # place in a pair).
    volume = smooth_noise((18, 20, 22), 7)
    volume[np.random.default_rng(3).random(volume.shape) < 0.15] = np.nan
    reference = isoslab.marching_cubes(volume, 0.0)
    assert len(reference[1]) > 1000
    for variant in (np.asfortranarray(volume), volume.astype(np.float64)):
        for got, want in zip(isoslab.marching_cubes(variant, 0.0), reference):
            np.testing.assert_array_equal(got, want)


def test_spacing_scales_the_vertices_only():
    volume = sphere_field()
    plain = isoslab.marching_cubes(volume, -6.0)
    scaled = isoslab.marching_cubes(volume, -6.0, spacing=(2.0, 0.5, 3.0))
    np.testing.assert_allclose(scaled[0], plain[0] * np.float32([2.0, 0.5, 3.0]), rtol=1e-6)
    np.testing.assert_array_equal(scaled[1], plain[1])
    np.testing.assert_array_equal(scaled[2], plain[2])


def test_default_level_is_the_middle_of_the_range():
    volume = sphere_field()
    middle = 0.5 * (float(volume.min()) + float(volume.max()))
    for got, want in zip(isoslab.marching_cubes(volume), isoslab.marching_cubes(volume, middle)):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("call, message", [
    (lambda v: isoslab.marching_cubes(v[0], 0.0), "should be a 3D numpy array \\(it has 2 dimensions\\)"),
    (lambda v: isoslab.marching_cubes(v, float("nan")), "must be a number, not NaN"),
    (lambda v: isoslab.marching_cubes(v, 100.0), "must be within volume data range"),
    (lambda v: isoslab.marching_cubes(v, -100.0), "must be within volume data range"),
    (lambda v: isoslab.marching_cubes(v, -6.0, spacing=(1, 1)), "three positive, finite floats"),
    (lambda v: isoslab.marching_cubes(v, -6.0, spacing=(1, 0, 1)), "three positive, finite floats"),
    (lambda v: isoslab.marching_cubes(v, -6.0, spacing="abc"), "three floats"),
    # float32 vertices (issue 33): the last index times 1e38 is beyond 3.4e38; a step of 1e-46 is
    # below float32's smallest step (1.4e-45).
    (lambda v: isoslab.marching_cubes(v, -6.0, spacing=(1, 1e38, 1)), r"`spacing` 1e\+38 along axis 1 puts the "
     "vertices beyond float32's range"),
    (lambda v: isoslab.marching_cubes(v, -6.0, spacing=(1e-46, 1, 1)), "below float32's resolution"),
    (lambda v: isoslab.marching_cubes(v, -6.0, method="marching"), "method should be one of 'lewiner', 'lorensen'"),
    (lambda v: isoslab.marching_cubes(v, -6.0, gradient_direction="up"), "gradient_direction should be"),
    (lambda v: isoslab.marching_cubes(v, -6.0, step_size=0), "step_size must be a whole number, at least one"),
    (lambda v: isoslab.marching_cubes(v, -6.0, step_size=1.5), "step_size must be a whole number"),
    (lambda v: isoslab.marching_cubes(v, -6.0, step_size=20), "leaves fewer than 2 lattice points"),
    (lambda v: isoslab.marching_cubes(v, -6.0, mask=np.ones((2, 2, 2), bool)), "volume and mask must have the same"),
    (lambda v: isoslab.marching_cubes(v[:1], -6.0), "at least 2x2x2"),
])
def test_bad_arguments_raise_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call(sphere_field())


def test_no_surface_raises_as_scikit_image():
    # At the smallest value every voxel is inside (isoslab counts values at the level as inside).
    volume = sphere_field()
    with pytest.raises(RuntimeError, match="No surface found"):
        isoslab.marching_cubes(volume, float(volume.min()))


def test_threads_of_python_run_at_once():
    # The GIL is released while extracting: threads give each the result of one call.
    volume = smooth_noise((40, 40, 40), 3)
    expected = isoslab.marching_cubes(volume, 0.0)
    results = [None] * 4

    def work(k):
        results[k] = isoslab.marching_cubes(volume, 0.0)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        np.testing.assert_array_equal(r[1], expected[1])


def test_calls_from_two_threads_overlap():
    # Equal results would also come from calls that ran one after the other. Here one thread makes
    # one long call while another makes short ones, and each notes when its calls start and end:
    # with the GIL released, short calls start and end all through the long one. Were the GIL held,
    # the short thread could not run during the long call's extraction, and its notes would leave a
    # gap that long (threads switch every 5 ms; the long call takes about a second). Wall-clock
    # times, so a busy machine slows both threads alike rather than separating them.
    big = smooth_noise((160, 160, 160), 5)  # about a second: a busy machine's pauses stay far shorter
    small = smooth_noise((12, 12, 12), 6)
    start = threading.Barrier(2)
    long_call = []
    notes = []
    done = threading.Event()

    def long_one():
        start.wait()
        t0 = time.perf_counter()
        isoslab.marching_cubes(big, 0.0, threads=1)
        long_call.extend([t0, time.perf_counter()])
        done.set()

    def short_ones():
        start.wait()
        while not done.is_set():
            notes.append(time.perf_counter())
            isoslab.marching_cubes(small, 0.0, threads=1)
            notes.append(time.perf_counter())

    threads = [threading.Thread(target=long_one), threading.Thread(target=short_ones)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    t0, t1 = long_call
    assert t1 - t0 > 0.05
    inside = [t0] + [t for t in notes if t0 < t < t1] + [t1]
    widest = max(b - a for a, b in zip(inside, inside[1:]))
    assert len(inside) > 10, f"{len(inside) - 2} short-call starts and ends during a {t1 - t0:.3f} s call"
    assert widest < 0.5 * (t1 - t0), f"a {widest:.3f} s pause of the short calls during a {t1 - t0:.3f} s call"


def test_extract_on_files_returns_the_report_and_writes_the_programs_bytes(tmp_path):
    report = isoslab.extract("phantom:sphere?n=32", tmp_path / "a.glb", iso=900, method="mt6", normals=True)
    subprocess.run([PROGRAM, "extract", "phantom:sphere?n=32", "--iso", "900", "--method", "mt6", "--normals", "-q",
                    "-o", str(tmp_path / "b.glb")], check=True)
    assert (tmp_path / "a.glb").read_bytes() == (tmp_path / "b.glb").read_bytes()
    assert report["method"] == "mt6"
    assert report["closed"] is True
    assert report["triangles"] > 0
    assert report["output"]["bytes"] == (tmp_path / "a.glb").stat().st_size


def test_extract_raises_the_programs_one_line(tmp_path):
    missing = tmp_path / "absent.nii"
    with pytest.raises(isoslab.Error) as e:
        isoslab.extract(missing, tmp_path / "x.ply", iso=1)
    single = subprocess.run([PROGRAM, "extract", str(missing), "--iso", "1", "-q", "-o", str(tmp_path / "y.ply")],
                            capture_output=True, text=True)
    assert single.stderr == f"isoslab: error: {e.value}\n"
    assert not (tmp_path / "x.ply").exists()


def test_extract_on_arrays_and_memmaps(tmp_path):
    raw, volume = phantom(tmp_path)
    expected = tmp_path / "expected.ply"
    subprocess.run([PROGRAM, "extract", str(raw), "--raw-dims", "24,22,20", "--raw-type", "i16", "--spacing",
                    "0.5,1,2", "--iso", "0", "-q", "-o", str(expected)], check=True)
    spacing = (2.0, 1.0, 0.5)  # axes (z, y, x)
    # An in-memory array (through a temporary raw file), a memmap (its own file), and a memmap
    # view that starts past the file's first slice.
    isoslab.extract(volume, tmp_path / "array.ply", iso=0, spacing=spacing)
    mapped = np.memmap(raw, "<i2", "r", shape=(20, 22, 24))
    report = isoslab.extract(mapped, tmp_path / "memmap.ply", iso=0, spacing=spacing)
    assert report["input"] == str(raw)
    for name in ("array.ply", "memmap.ply"):
        assert (tmp_path / name).read_bytes() == expected.read_bytes(), name
    isoslab.extract(mapped[5:], tmp_path / "view.ply", iso=0)
    direct = isoslab.marching_cubes(volume[5:].astype(np.float32), 0.0, method="mc")
    verts, faces = read_ply(tmp_path / "view.ply")
    np.testing.assert_array_equal(verts, direct[0][:, ::-1])
    np.testing.assert_array_equal(faces, direct[1])


def test_read_volume_info_and_iter_slices_read_what_numpy_reads(tmp_path):
    nii = tmp_path / "head.nii"
    subprocess.run([PROGRAM, "phantom", "phantom:head?n=24,22,20", "-o", str(nii)], check=True, capture_output=True)
    data = open(nii, "rb").read()
    offset = int(np.frombuffer(data, "<f4", 1, 108)[0])
    expected = np.frombuffer(data, "<i2", 24 * 22 * 20, offset).reshape(20, 22, 24)
    info = isoslab.read_volume_info(nii)
    assert info["shape"] == (20, 22, 24)
    assert info["dims"] == (24, 22, 20)
    assert info["voxel_type"] == "i16"
    assert info["reader"] == "nifti1"
    slices = list(isoslab.iter_slices(nii))
    assert len(slices) == 20
    for k, (values, geometry) in enumerate(slices):
        assert values.dtype == np.float32 and values.shape == (22, 24)
        np.testing.assert_array_equal(values, expected[k])
        assert geometry["index"] == k
        np.testing.assert_allclose(geometry["origin"], np.array(info["origin"]) + k * np.array(info["spacing"][2]) *
                                   np.array(info["direction"]).reshape(3, 3)[:, 2])
    with pytest.raises(isoslab.Error, match="absent.nii"):
        isoslab.read_volume_info(tmp_path / "absent.nii")


def test_metrics_of_any_mesh():
    verts, faces, _, _ = isoslab.marching_cubes(sphere_field((40, 40, 40), (19.5, 19.5, 19.5)), -12.0)
    m = isoslab.metrics(verts, faces, sphere=(19.5, 19.5, 19.5, 12.0))
    assert m["closed"] is True
    assert m["components"]["count"] == 1
    assert m["triangles"] == len(faces)
    assert m["area"] == pytest.approx(measure.mesh_surface_area(verts, faces), rel=1e-6)
    assert m["area"] == pytest.approx(4 * np.pi * 144, rel=0.02)
    assert abs(m["volume"]) == pytest.approx(4 / 3 * np.pi * 12 ** 3, rel=0.02)
    assert "sphere" in m
    with pytest.raises(ValueError, match="refers to vertex"):
        isoslab.metrics(verts, faces + len(verts))
