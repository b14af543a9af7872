"""isoslab from Python: streaming iso-surface extraction from volumes.

- marching_cubes(volume, level, ...): scikit-image's calling convention on a NumPy array, with
  isoslab's methods (mc, mt5, mt6, bcc12, mt24, mc33).
- extract(inputs, output, iso=..., ...): the `isoslab extract` job on files or an array; returns
  its report as a dict.
- read_volume_info(path) and iter_slices(path): the readers alone.
- metrics(verts, faces, sphere=None): mesh statistics and the paper's measures for any mesh.
"""
import json
import math
import os
import subprocess
import tempfile

import numpy as np

from . import _isoslab
from ._program import PROGRAM as _PROGRAM

__version__ = _isoslab.__version__
Error = _isoslab.Error

__all__ = ["marching_cubes", "extract", "read_volume_info", "iter_slices", "metrics", "Error", "__version__"]

_METHODS = ("mc", "mt5", "mt6", "bcc12", "mt24", "mc33")


def _check_float32_reach(spacing, shape):
    """Vertices are float32: along each axis, the farthest vertex (spacing times the last index)
    must be finite there, and a step must span at least one of float32's steps at that distance,
    as `isoslab extract` requires (issue 33)."""
    f32 = np.finfo(np.float32)
    for axis, (s, n) in enumerate(zip(spacing, shape)):
        reach = s * max(int(n) - 1, 0)
        if reach > float(f32.max):
            raise ValueError(f"`spacing` {s:g} along axis {axis} puts the vertices beyond float32's range: "
                             f"its {n} points reach {reach:.3g} (the largest float32 is {float(f32.max):.3g}).")
        resolution = float(np.spacing(np.float32(max(reach, float(f32.tiny)))))
        if s < resolution:
            raise ValueError(f"`spacing` {s:g} along axis {axis} is below float32's resolution at the vertices' "
                             f"coordinates (which reach {reach:.3g}, where float32 steps by {resolution:.3g}): "
                             f"neighbouring vertices would coincide.")


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), method="mc", gradient_direction="descent",
                   step_size=1, allow_degenerate=True, mask=None, threads=None):
    """The iso-surface of a 3D array at `level`, as skimage.measure.marching_cubes returns it.

    Returns (verts, faces, normals, values):
    - verts (V, 3) float32: positions in array index order (axis 0, 1, 2), times `spacing`;
    - faces (F, 3) int32: vertex indices; with gradient_direction "descent" (the object is
      brighter than its surroundings) in scikit-image's order, "ascent" reversed;
    - normals (V, 3) float32: unit normals of the field's gradient in index space, from higher to
      lower values (as scikit-image's, whatever gradient_direction);
    - values (V,) float32: per vertex, the largest span of values (max - min) of a cell around
      it, scikit-image's measure for colour maps.

    The vertices are welded (each once). `level` defaults to the middle of the data's range and
    must lie within it. `method`: "mc" (Lorensen's cases, as skimage's "lorensen"), "mt5",
    "mt6", "bcc12" (marching tetrahedra), "mt24", "mc33". `threads`: extraction threads (default
    1). A C-contiguous float32 array is read in place, one slice at a time; other dtypes and
    strides are converted a slice at a time. The GIL is released while extracting.
    `step_size` other than 1 and `mask` are not supported (ValueError).
    """
    if not isinstance(volume, np.ndarray):
        volume = np.asarray(volume)
    if volume.ndim != 3:
        raise ValueError(f"Input volume should be a 3D numpy array (it has {volume.ndim} dimensions).")
    if min(volume.shape) < 2:
        raise ValueError(f"Input array must be at least 2x2x2 (its shape is {volume.shape}).")
    if method not in _METHODS:
        raise ValueError(f"method should be one of {', '.join(repr(m) for m in _METHODS)} (got {method!r}).")
    if gradient_direction not in ("descent", "ascent"):
        raise ValueError(f"gradient_direction should be 'descent' or 'ascent' (got {gradient_direction!r}).")
    try:
        spacing = tuple(float(s) for s in spacing)
    except (TypeError, ValueError):
        raise ValueError(f"`spacing` must consist of three floats (got {spacing!r}).") from None
    if len(spacing) != 3 or not all(math.isfinite(s) and s > 0 for s in spacing):
        raise ValueError(f"`spacing` must consist of three positive, finite floats (got {spacing!r}).")
    _check_float32_reach(spacing, np.shape(volume))
    if int(step_size) != 1:
        raise ValueError(f"step_size {step_size} is not supported: isoslab visits every cell (use step_size=1).")
    if mask is not None:
        raise ValueError("mask is not supported: crop the volume instead (isoslab extract --roi for files).")
    if threads is not None and int(threads) < 1:
        raise ValueError(f"threads must be at least 1 (got {threads}).")
    lo, hi = _isoslab.volume_range(volume)
    if level is None:
        if math.isnan(lo):
            raise ValueError("The volume holds no values but NaN.")
        level = 0.5 * (lo + hi)
    else:
        level = float(level)
        if math.isnan(level):
            raise ValueError("Surface level must be a number, not NaN.")
        if math.isnan(lo) or level < lo or level > hi:
            raise ValueError(f"Surface level must be within volume data range ({lo} .. {hi}; got {level}).")
    verts, faces, normals, values = _isoslab.marching_cubes(volume, level, spacing, method,
                                                             int(threads or 1), gradient_direction == "ascent")
    if len(verts) == 0:
        raise RuntimeError("No surface found at the given iso value.")
    if not allow_degenerate:
        verts, faces, normals, values = _remove_degenerate(verts, faces, normals, values)
    return verts, faces, normals, values


def _remove_degenerate(verts, faces, normals, values):
    """Drops triangles with two vertices at one position, and vertices no triangle uses then."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    keep = ~((a == b).all(1) | (a == c).all(1) | (b == c).all(1))
    faces = faces[keep]
    used = np.zeros(len(verts), bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used, dtype=np.int64) - 1
    return verts[used], remap[faces].astype(np.int32), normals[used], values[used]


def _flag(name):
    return "--" + name.replace("_", "-")


def extract(inputs, output, *, iso, method="mc", spacing=None, **options):
    """Runs `isoslab extract` on files (a path or a list of paths: DICOM folders, NIfTI, NRRD,
    MetaImage, image stacks, raw with raw_dims=...) or on a 3D NumPy array, writing `output`
    (.glb, .ply, .stl, .obj, .drc). Returns the run's report as a dict.

    Options are the command's, with underscores: normals=True, close_boundary=True,
    threads=2, smooth=10, keep_largest=1, roi="0,0,0,99,99,99", raw_dims=(256, 256, 113), ...
    (True gives the flag, a sequence a comma list). `iso` may be a number or "auto", "bone",
    "skin". An array is given to the command without a copy in memory: an np.memmap of a file
    is read from its file, slice by slice, and another array is written to a temporary raw file
    slice by slice first. Its axes are (slices, rows, columns), and `spacing` follows them.
    Raises isoslab.Error with the command's one-line message when it fails.
    """
    args = []
    temporary = None
    try:
        if isinstance(inputs, np.ndarray):
            args, temporary = _array_input(inputs, spacing)
        else:
            args = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
            args = [os.fspath(a) for a in args]
            if spacing is not None:
                options["spacing"] = spacing
        args += ["--iso", str(iso), "--method", str(method), "-o", os.fspath(output)]
        for name, value in options.items():
            if value is None or value is False:
                continue
            if value is True:
                args.append(_flag(name))
            elif isinstance(value, (list, tuple)):
                args += [_flag(name), ",".join(str(v) for v in value)]
            else:
                args += [_flag(name), str(value)]
        with tempfile.TemporaryDirectory(prefix="isoslab-") as folder:
            report = os.path.join(folder, "report.json")
            run = subprocess.run([_PROGRAM, "extract", *args, "-q", "--report", report], capture_output=True,
                                 text=True)
            if run.returncode != 0:
                lines = [line for line in run.stderr.splitlines() if line.startswith("isoslab: error: ")]
                message = lines[-1][len("isoslab: error: "):] if lines else run.stderr.strip()
                raise Error(message)
            with open(report) as f:
                return json.load(f)
    finally:
        if temporary is not None:
            os.unlink(temporary)


_RAW_TYPES = {("u", 1): "u8", ("i", 1): "i8", ("u", 2): "u16", ("i", 2): "i16", ("u", 4): "u32", ("i", 4): "i32",
              ("f", 4): "f32", ("f", 8): "f64", ("b", 1): "u8"}


_RAW_DTYPES = {"u8": "u1", "i8": "i1", "u16": "<u2", "i16": "<i2", "u32": "<u4", "i32": "<i4", "f32": "<f4",
               "f64": "<f8"}


def _array_input(volume, spacing):
    """The command's input for an array: its memmap'ed file, or a temporary raw file."""
    if volume.ndim != 3:
        raise ValueError(f"Input volume should be a 3D numpy array (it has {volume.ndim} dimensions).")
    nz, ny, nx = volume.shape
    raw_type = _RAW_TYPES.get((volume.dtype.kind, volume.dtype.itemsize))
    args = []
    temporary = None
    # A memmap of a file, unless copy-on-write (mode "c": its changes are not in the file).
    file_backed = (isinstance(volume, np.memmap) and getattr(volume, "filename", None) and raw_type
                   and getattr(volume, "mode", "c") != "c" and volume.flags.c_contiguous
                   and volume.dtype.byteorder in ("=", "<", "|"))
    if file_backed:
        # The root memmap's data starts at its `offset` in the file; a view starts further on.
        root = volume
        while isinstance(root.base, np.memmap):
            root = root.base
        start = volume.__array_interface__["data"][0] - root.__array_interface__["data"][0]
        args = [os.fspath(volume.filename), "--raw-offset", str(int(root.offset) + start)]
    else:
        raw_type = raw_type or "f32"
        dtype = np.dtype(_RAW_DTYPES[raw_type])
        fd, temporary = tempfile.mkstemp(prefix="isoslab-", suffix=".raw")
        try:
            with os.fdopen(fd, "wb") as f:
                for k in range(nz):
                    f.write(np.ascontiguousarray(volume[k], dtype=dtype).tobytes())
        except BaseException:
            os.unlink(temporary)  # a full disk or an interrupt leaves no temporary file
            raise
        args = [temporary]
    args += ["--raw-dims", f"{nx},{ny},{nz}", "--raw-type", raw_type, "--raw-endian", "little"]
    if spacing is not None:
        s = tuple(float(v) for v in spacing)
        args += ["--spacing", f"{s[2]},{s[1]},{s[0]}"]
    return args, temporary


def read_volume_info(path):
    """The geometry of a volume file (or a list of files) without reading its voxels: shape (in
    array order: slices, rows, columns), dims (x, y, z), spacing, origin, direction (row-major
    3 x 3, columns per axis), voxel_type, reader, modality, value_range where the header gives it."""
    return _isoslab.read_volume_info(_paths(path))


def iter_slices(path):
    """Yields (values, geometry) for each slice of a volume, in order: values a float32 array
    (rows, columns), geometry a dict with the slice's index, origin, spacing and direction. One
    slice is in memory at a time."""
    reader = _isoslab.SliceReader(_paths(path))
    yield from reader


def _paths(path):
    return [os.fspath(path)] if isinstance(path, (str, os.PathLike)) else [os.fspath(p) for p in path]


def metrics(verts, faces, sphere=None):
    """Statistics of any triangle mesh (counts, area, volume, edges, closedness, components) and,
    with sphere=(cx, cy, cz, r), the paper's measures against that sphere, as `isoslab metrics`
    reports them."""
    verts = np.asarray(verts)
    faces = np.asarray(faces)
    if sphere is not None:
        sphere = tuple(float(v) for v in sphere)
        if len(sphere) != 4:
            raise ValueError(f"sphere must be (cx, cy, cz, r) (got {sphere!r}).")
    return json.loads(_isoslab.metrics(verts, faces, sphere))
