"""Fields and mesh comparisons that the Python tests share."""
import numpy as np
from scipy.spatial import cKDTree


def smooth_noise(shape, seed):
    """Random but smooth float32 field (no value equals another by chance)."""
    rng = np.random.default_rng(seed)
    f = rng.standard_normal(shape)
    for axis in range(3):  # a few box blurs: many small, closed and open pieces
        f = (f + np.roll(f, 1, axis) + np.roll(f, -1, axis)) / 3
    return f.astype(np.float32)


def same_vertex_sets(a, b, tol=1e-5):
    """Every vertex of a within tol of one of b and the other way round, as many of each."""
    if len(a) != len(b):
        return False
    da, _ = cKDTree(b).query(a)
    db, _ = cKDTree(a).query(b)
    return da.max() <= tol and db.max() <= tol
