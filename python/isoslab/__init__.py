"""isoslab from Python: streaming iso-surface extraction from volumes.

- marching_cubes(volume, level, ...): scikit-image's calling convention on a NumPy array, with
  isoslab's methods (mc, mt5, mt6, bcc12, mt24, mc33).
- extract(inputs, output, iso=..., ...): the `isoslab extract` job, in process, on files or an
  array; returns its report as a dict.
- read_volume_info(path) and iter_slices(path): the readers alone.
- metrics(verts, faces, sphere=None): mesh statistics and the paper's measures for any mesh.
"""
import json
import math
import os
import sys

import numpy as np

from . import _isoslab

__version__ = _isoslab.__version__
Error = _isoslab.Error

__all__ = ["marching_cubes", "extract", "label_surfaces", "read_volume_info", "iter_slices", "metrics", "Error",
           "__version__"]

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


# scikit-image's method names: "lewiner" is its topologically correct MC33 (Lewiner et al.),
# "lorensen" and "_lorensen" the classic cases (the second returns only verts and faces).
_SKIMAGE_METHODS = {"lewiner": "mc33", "lorensen": "mc", "_lorensen": "mc"}


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent", step_size=1,
                   allow_degenerate=True, method="lewiner", mask=None, threads=None):
    """The iso-surface of a 3D array at `level`, as skimage.measure.marching_cubes (0.19) returns it,
    so that scikit-image's own calls run unchanged.

    Returns (verts, faces, normals, values), or (verts, faces) for method "_lorensen":
    - verts (V, 3) float32: positions in array index order (axis 0, 1, 2), times `spacing`;
    - faces (F, 3) int32: vertex indices; with gradient_direction "descent" (the object is
      brighter than its surroundings) in scikit-image's order, "ascent" reversed;
    - normals (V, 3) float32: unit normals of the field's gradient in index space, from higher to
      lower values (as scikit-image's, whatever gradient_direction);
    - values (V,) float32: per vertex, the largest span of values (max - min) of a cell around
      it, scikit-image's measure for colour maps.

    The vertices are welded (each once). `level` defaults to the middle of the data's range and
    must lie within it. `method`: scikit-image's "lewiner" (the default: isoslab's mc33,
    topologically correct), "lorensen" or "_lorensen" (isoslab's mc, Lorensen's cases), or any of
    isoslab's: "mc", "mt5", "mt6", "bcc12", "mt24", "mc33". `step_size` N extracts on every N-th
    lattice point along each axis (vertices still in the full array's index space, as
    scikit-image's). `mask`: a boolean array of the volume's shape; a cell gives triangles only
    where the mask holds at its corner of highest indices, as in scikit-image 0.19. `threads`:
    extraction threads (default 1). A C-contiguous float32 array is read in place, one slice at a
    time; other dtypes and strides are converted a slice at a time. The GIL is released while
    extracting.
    """
    if not isinstance(volume, np.ndarray):
        volume = np.asarray(volume)
    if volume.ndim != 3:
        raise ValueError(f"Input volume should be a 3D numpy array (it has {volume.ndim} dimensions).")
    if min(volume.shape) < 2:
        raise ValueError(f"Input array must be at least 2x2x2 (its shape is {volume.shape}).")
    classic_only = method == "_lorensen"
    kernel = _SKIMAGE_METHODS.get(method, method)
    if kernel not in _METHODS:
        names = list(_SKIMAGE_METHODS) + list(_METHODS)
        raise ValueError(f"method should be one of {', '.join(repr(m) for m in names)} (got {method!r}).")
    if gradient_direction not in ("descent", "ascent"):
        raise ValueError(f"gradient_direction should be 'descent' or 'ascent' (got {gradient_direction!r}).")
    try:
        spacing = tuple(float(s) for s in spacing)
    except (TypeError, ValueError):
        raise ValueError(f"`spacing` must consist of three floats (got {spacing!r}).") from None
    if len(spacing) != 3 or not all(math.isfinite(s) and s > 0 for s in spacing):
        raise ValueError(f"`spacing` must consist of three positive, finite floats (got {spacing!r}).")
    _check_float32_reach(spacing, np.shape(volume))
    if mask is not None:
        if classic_only:
            raise NotImplementedError('Parameter `mask` is not implemented for method "_lorensen" and will be '
                                      'ignored.')
        mask = np.asarray(mask)
        if mask.shape != volume.shape:
            raise ValueError(f"volume and mask must have the same shape ({volume.shape} and {mask.shape}).")
        mask = mask.astype(bool, copy=False)
    if int(step_size) != step_size or int(step_size) < 1:
        raise ValueError(f"step_size must be a whole number, at least one (got {step_size!r}).")
    step = int(step_size)
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
    lattice = volume
    if step > 1:
        # Every step-th point, as scikit-image's cells of `step` points: the view is read a slice
        # at a time, and its spacing is `step` of the volume's.
        lattice = volume[::step, ::step, ::step]
        if min(lattice.shape) < 2:
            raise ValueError(f"step_size {step} leaves fewer than 2 lattice points on an axis of {volume.shape}.")
        spacing = tuple(s * step for s in spacing)
    verts, faces, normals, values = _isoslab.marching_cubes(lattice, level, spacing, kernel,
                                                             int(threads or 1), gradient_direction == "ascent")
    if mask is not None:
        verts, faces, normals, values = _masked(verts, faces, normals, values, mask, spacing, step)
    if len(verts) == 0:
        raise RuntimeError("No surface found at the given iso value.")
    if not allow_degenerate:
        verts, faces, normals, values = _remove_degenerate(verts, faces, normals, values)
    if classic_only:
        return verts, faces
    return verts, faces, normals, values


def _masked(verts, faces, normals, values, mask, spacing, step):
    """The triangles of the cells whose corner of highest indices the mask holds (scikit-image's
    rule), and the vertices they use. A triangle lies in one cell: its centroid's cell."""
    centroid = verts[faces].astype(np.float64).mean(axis=1) / np.asarray(spacing)
    shape = np.array([(n - 1) // step + 1 for n in mask.shape])
    cell = np.clip(np.floor(centroid).astype(np.int64), 0, shape - 2)
    corner = (cell + 1) * step
    keep = mask[corner[:, 0], corner[:, 1], corner[:, 2]]
    faces = faces[keep]
    used = np.zeros(len(verts), bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used, dtype=np.int64) - 1
    return verts[used], remap[faces].astype(np.int32), normals[used], values[used]


def _remove_degenerate(verts, faces, normals, values):
    """Drops triangles with two vertices at one position, and vertices no triangle uses then."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    keep = ~((a == b).all(1) | (a == c).all(1) | (b == c).all(1))
    faces = faces[keep]
    used = np.zeros(len(verts), bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used, dtype=np.int64) - 1
    return verts[used], remap[faces].astype(np.int32), normals[used], values[used]


# extract()'s options: the program's, with underscores (job/extract_settings.h).
_EXTRACT_OPTIONS = {
    "series", "strict", "skip_bad", "channel", "nifti_xform", "raw_dims", "raw_type", "raw_endian", "raw_offset",
    "space", "normals", "close_boundary", "keep_degenerate", "report", "sphere", "threads", "max_memory",
    "sequential_voxels",
    "draco_level", "quant_bits", "chunk_triangles", "draco", "gltf_frame", "roi", "roi_space", "keep_largest",
    "component_measure", "min_triangles", "min_volume", "seed", "smooth", "smooth_method", "pass_band",
    "smooth_faces", "smooth_normals", "decimate", "max_error", "preview", "quiet", "labels", "label_table"}
# Options that take several numbers: a sequence, or the program's comma-separated text.
_LIST_OPTIONS = {"raw_dims", "sphere", "roi", "seed", "spacing"}


def _numbers(name, value):
    if isinstance(value, str):
        value = value.split(",")
    try:
        return [float(v) for v in value]
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a sequence of numbers (got {value!r}).") from None


def _spacing(value):
    # An array's spacing, in its axes' order: three finite positive numbers.
    numbers = _numbers("spacing", value)
    if len(numbers) != 3 or not all(math.isfinite(v) and v != 0 for v in numbers):
        raise ValueError(f"spacing must be three finite numbers other than 0, one per array axis (got {value!r}).")
    return numbers


def _whole(name, value, least, most):
    # A count: an int (a NumPy integer too; not a bool, not a float, which would be truncated).
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be a whole number (got {value!r}).")
    if not least <= value <= most:
        raise ValueError(f"{name} must be from {least} to {most} (got {value}).")
    return int(value)


def _terminal_progress():
    """A progress bar on stderr (Debian's python3-tqdm) when stderr is a terminal, else None."""
    if not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    bar = tqdm(total=1.0, desc="isoslab: ", leave=False,
               bar_format="{desc}{percentage:3.0f}%|{bar}| {elapsed}<{remaining}")  # set_description adds ": "

    def show(fraction, stage):
        bar.set_description(f"isoslab {stage}", refresh=False)
        bar.update(fraction - bar.n)
        if fraction >= 1:
            bar.refresh()  # 100% is drawn even within tqdm's redraw interval
            bar.close()
    return show


def _progress_callback(progress):
    """What a `progress` argument asks for: a callable as it is; None or True, the terminal's bar
    (none where stderr is no terminal or tqdm is absent); False, none."""
    if isinstance(progress, np.bool_):
        progress = bool(progress)
    if progress is None or progress is True:
        return _terminal_progress()
    if progress is False:
        return None
    if not callable(progress):
        raise TypeError(f"progress must be callable, True or False (got {type(progress).__name__} {progress!r}).")
    return progress


def extract(inputs, output, *, iso=None, method="mc", spacing=None, progress=None, **options):
    """Runs the `isoslab extract` job in this process on files (a path or a list of paths: DICOM
    folders, NIfTI, NRRD, MetaImage, image stacks, raw with raw_dims=...) or on a 3D NumPy array,
    writing `output` (.glb, .ply, .stl, .obj, .drc, .3mf). Returns the run's report as a dict (the
    program's --report).

    Options are the program's, with underscores: normals=True, close_boundary=True, threads=2,
    smooth=10, keep_largest=1, roi=(0, 0, 0, 99, 99, 99), raw_dims=(256, 256, 113), report="r.json",
    ... (lists as sequences or comma-separated text). `iso` may be a number or "auto", "bone",
    "skin" (None: the input's suggestion, for phantoms), or a list of numbers: one surface each, in
    one pass. A label map (NIfTI label intent, .seg.nrrd, DICOM SEG) gives one surface per label
    without `iso`; labels="all" or labels=[3, "7-9", "Hippocampus_L"] selects, label_table= names
    them, and `output` may be a pattern ("organs/{name}.stl"); the report's "labels" and
    "label_interfaces" describe each. An array is read in place, a slice at a
    time, without a copy or a temporary file; its axes are (slices, rows, columns), and `spacing`
    follows them. The GIL is released while the job runs.

    `progress`: a callable progress(fraction, stage), called on this thread with fractions rising
    to 1 (stage "components" for a component filter's first pass, then "extract"); an exception it
    raises stops the run and is raised here. Left out, a progress bar is shown when stderr is a
    terminal and tqdm is installed (True too); False shows none. Ctrl-C stops the run within a slab and raises
    KeyboardInterrupt. A stopped or failed run leaves no output. Errors raise isoslab.Error with the
    program's one-line message.
    """
    unknown = sorted(set(options) - _EXTRACT_OPTIONS)
    if unknown:
        raise TypeError(f"extract() got an unexpected keyword argument {unknown[0]!r}")
    settings = {"output": os.fspath(output), "method": str(method)}
    if isinstance(iso, (list, tuple, np.ndarray)) or (isinstance(iso, str) and "," in iso):
        settings["isos"] = _numbers("iso", iso)  # several surfaces in one pass
    elif iso is not None:
        settings["iso"] = iso if isinstance(iso, str) else float(iso)
    volume = None
    if isinstance(inputs, np.ndarray):
        volume = inputs
        if volume.ndim != 3:
            raise ValueError(f"Input volume should be a 3D numpy array (it has {volume.ndim} dimensions).")
        # A memmap is named by its file in messages and the report; another array as "array".
        name = getattr(volume, "filename", None) if isinstance(volume, np.memmap) else None
        settings["inputs"] = [os.fspath(name) if name else "array"]
        if spacing is not None:
            settings["array_spacing"] = _numbers("spacing", spacing)
    else:
        paths = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
        settings["inputs"] = [os.fspath(p) for p in paths]
        if spacing is not None:
            settings["spacing"] = _numbers("spacing", spacing)
    for name, value in options.items():
        if value is None or name == "quiet":
            continue
        if name in _LIST_OPTIONS:
            value = _numbers(name, value)
            if name == "raw_dims":
                value = [int(v) for v in value]
        elif name == "draco" and isinstance(value, bool):
            value = "on" if value else "off"
        elif name in ("report", "preview", "label_table"):
            value = os.fspath(value)
        elif name == "labels":
            value = _label_list(value)
        settings[name] = value
    progress = _progress_callback(progress)
    return json.loads(_isoslab.extract(settings, volume, progress))


def _label_list(value):
    # "all", a value, or a list of values, ranges ("7-9") and names, as --labels takes them.
    if isinstance(value, np.ndarray):
        value = value.tolist()
    return ",".join(str(v) for v in value) if isinstance(value, (list, tuple, set)) else str(value)


def label_surfaces(labels, *, spacing=(1.0, 1.0, 1.0), select=None, smooth=0, decimate=1.0, keep_largest=None,
                   min_volume=None, threads=None, progress=False):
    """Every label's surface of a label map held in a 3D NumPy integer array, in one streaming pass
    (as `isoslab extract` meshes a segmentation; the array is read in place, a slice at a time).

    Returns (surfaces, adjacency):
    - surfaces: {label: (verts, faces)} per label present (0 is the background), in scikit-image's
      index order: verts (V, 3) float32 as (plane, row, column) times `spacing`, faces (F, 3) int32
      ordered as skimage.measure.marching_cubes orders a mask's ("descent"). Each surface is closed;
      where two labels touch they share the same vertex positions and triangles (reversed);
    - adjacency: {(a, b): area} for each pair of labels that touch (a < b).

    `select`: None or "all" for every label, else values, ranges ("7-9") as --labels takes them.
    `smooth`: iterations of the label complex's constrained smoothing (as extract's --smooth on a
    label map: each interface moves once for both labels). `decimate`: the fraction of the label
    complex's triangles to keep (as extract's --decimate on a label map: each collapse is made for
    both labels, within a voxel of the surface; lines where three labels meet are simplified along
    themselves).
    `keep_largest`, `min_volume`: each label's connected components (6-connected voxels) kept, as
    extract's --keep-largest and --min-volume take them on a label map: the N largest by triangles,
    those of at least this volume (voxels times the voxel volume, in `spacing`'s units cubed); a
    dropped component's voxels go to the label around it (the one sharing the most voxel faces with
    it, or the background), so the surfaces stay closed and shared. The array is read twice.
    `threads`: None for the default. Errors raise isoslab.Error with the program's message.
    """
    if not isinstance(labels, np.ndarray):
        raise TypeError(f"labels must be a NumPy array (got {type(labels).__name__}).")
    if labels.ndim != 3:
        raise ValueError(f"labels should be a 3D numpy array (it has {labels.ndim} dimensions).")
    if labels.dtype.kind not in "iub":
        raise ValueError(f"labels should hold integers (its dtype is {labels.dtype}).")
    name = getattr(labels, "filename", None) if isinstance(labels, np.memmap) else None
    settings = {"output": "", "method": "mc", "inputs": [os.fspath(name) if name else "array"],
                "labels": "all" if select is None else _label_list(select),
                "array_spacing": _spacing(spacing)}
    if threads is not None:
        settings["threads"] = _whole("threads", threads, 1, 256)
    if smooth:
        settings["smooth"] = _whole("smooth", smooth, 0, 500)
    if decimate != 1.0:
        settings["decimate"] = float(decimate)
    if keep_largest is not None:
        settings["keep_largest"] = _whole("keep_largest", keep_largest, 1, 2**63 - 1)
    if min_volume is not None:
        settings["min_volume"] = float(min_volume)
    progress = _progress_callback(progress)
    found, report = _isoslab.label_surfaces(settings, labels, progress)
    surfaces = {int(label): (verts, faces) for label, _, verts, faces in found}
    adjacency = {}
    for face in json.loads(report).get("label_interfaces", []):
        a, b = sorted(int(v) for v in face["labels"])
        adjacency[(a, b)] = float(face["area"])
    return surfaces, adjacency


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
