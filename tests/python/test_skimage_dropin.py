"""isoslab.marching_cubes as a drop-in for scikit-image 0.19's (issue 34): scikit-image's own test
module run against it, and mask= and step_size= against scikit-image's results."""
import importlib.util
import os

import numpy as np
import pytest
from skimage import measure

import isoslab
from fields import same_vertex_sets, smooth_noise

SKIMAGE_TESTS = "/usr/lib/python3/dist-packages/skimage/measure/tests/test_marching_cubes.py"
IMPORT = "from skimage.measure import marching_cubes, mesh_surface_area"


@pytest.fixture(scope="module")
def skimage_module(tmp_path_factory):
    """scikit-image's test module, copied with its import of marching_cubes replaced by isoslab's."""
    if not os.path.exists(SKIMAGE_TESTS):
        pytest.skip(f"{SKIMAGE_TESTS} is absent (Debian: python3-skimage)")
    text = open(SKIMAGE_TESTS).read()
    assert text.count(IMPORT) == 1, "scikit-image's test module changed: review this test"
    text = text.replace(IMPORT, "from skimage.measure import mesh_surface_area\nfrom isoslab import marching_cubes")
    path = tmp_path_factory.mktemp("skimage") / "test_marching_cubes_isoslab.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("test_marching_cubes_isoslab", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.marching_cubes is isoslab.marching_cubes
    return module


def skimage_test_names():
    if not os.path.exists(SKIMAGE_TESTS):
        return ["absent"]
    return [line.split("(")[0][4:] for line in open(SKIMAGE_TESTS) if line.startswith("def test_")]


@pytest.mark.parametrize("name", skimage_test_names())
def test_scikit_images_own_tests_pass_with_isoslab(skimage_module, name):
    getattr(skimage_module, name)()


def test_the_copied_module_can_fail(skimage_module, monkeypatch):
    # A marching_cubes that drops a triangle must fail scikit-image's area test.
    def broken(*args, **kwargs):
        verts, faces, *rest = isoslab.marching_cubes(*args, **kwargs)
        return (verts, faces[len(faces) // 10:], *rest)
    monkeypatch.setattr(skimage_module, "marching_cubes", broken)
    with pytest.raises(AssertionError):
        skimage_module.test_marching_cubes_isotropic()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mask_gives_scikit_images_vertices_and_triangles(seed):
    volume = smooth_noise((26, 30, 28), seed)
    rng = np.random.default_rng(seed + 10)
    mask = rng.random(volume.shape) < 0.6  # scattered: most cells have masked and unmasked neighbours
    mask[:, :, 20:] = False
    spacing = (1.0, 2.0, 0.5)
    verts, faces, _, _ = isoslab.marching_cubes(volume, 0.05, spacing=spacing, method="lorensen", mask=mask)
    sv, sf, _, _ = measure.marching_cubes(volume, 0.05, spacing=spacing, method="lorensen", mask=mask)
    full = isoslab.marching_cubes(volume, 0.05, spacing=spacing, method="lorensen")[1]
    assert 0 < len(faces) < 0.7 * len(full)
    assert len(faces) == len(sf)
    # scikit-image keeps every vertex it made, used or not: compare the used ones.
    assert same_vertex_sets(verts, sv[np.unique(sf)].astype(np.float32))


@pytest.mark.parametrize("step", [2, 3])
def test_step_size_gives_scikit_images_vertices_and_triangles(step):
    volume = smooth_noise((31, 29, 34), step)
    spacing = (0.5, 1.0, 2.0)
    verts, faces, normals, _ = isoslab.marching_cubes(volume, 0.02, spacing=spacing, method="lorensen",
                                                      step_size=step)
    sv, sf, sn, _ = measure.marching_cubes(volume, 0.02, spacing=spacing, method="lorensen", step_size=step)
    assert len(faces) == len(sf) > 100
    assert same_vertex_sets(verts, sv[np.unique(sf)].astype(np.float32), tol=1e-4)
    # In the full array's index space: vertices on the coarse lattice's edges.
    index = verts / np.float32(spacing)
    on_lattice = np.abs(index / step - np.round(index / step)) < 1e-4
    assert (on_lattice.sum(axis=1) >= 2).all()


def test_method_names_mean_what_they_mean_in_scikit_image():
    volume = smooth_noise((20, 22, 24), 5)
    lewiner = isoslab.marching_cubes(volume, 0.05)
    mc33 = isoslab.marching_cubes(volume, 0.05, method="mc33")
    lorensen = isoslab.marching_cubes(volume, 0.05, method="lorensen")
    mc = isoslab.marching_cubes(volume, 0.05, method="mc")
    for a, b in ((lewiner, mc33), (lorensen, mc)):
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)
    assert len(isoslab.marching_cubes(volume, 0.05, method="_lorensen")) == 2
    with pytest.raises(NotImplementedError):
        isoslab.marching_cubes(volume, 0.05, method="_lorensen", mask=np.ones(volume.shape, bool))
    with pytest.raises(ValueError, match="step_size"):
        isoslab.marching_cubes(volume, 0.05, step_size=0)
