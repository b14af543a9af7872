#!/usr/bin/env bash
# Regenerates the fuzz targets' seed corpora in tests/fuzz/corpus/<target>/ with isoslab's own
# writers: `isoslab phantom` (raw, NRRD, MetaImage, NIfTI), `isoslab extract` (PLY, STL, OBJ, GLB,
# DRC), samples/make_dicom_series (DICOM) and fuzz_make_images (PNG and TIFF through OpenImageIO),
# then packs them into the targets' input layouts (tests/fuzz/fuzz_*.cpp describe them). Inputs
# named regress_* (reproducers of fixed findings) are kept.
#   scripts/make_fuzz_corpus.sh [BUILD_DIR]    (default build-fuzz; builds the tools it needs)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-fuzz}
ninja -C "$build" isoslab make_dicom_series make_dicom_seg fuzz_make_images >/dev/null
export ASAN_OPTIONS=detect_leaks=0
cli=$build/cli/isoslab
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
out=tests/fuzz/corpus
# Inputs named regress_* are reproducers of fixed findings, kept as seeds: not regenerated.
mkdir -p "$out"
find "$out" -type f ! -name 'regress_*' -delete
mkdir -p "$out"/{raw,volume,dicom,image_stack,mesh,extract}
q() { "$@" >/dev/null; }

# Volumes: small phantoms of several voxel types, attached and compressed.
sphere='phantom:sphere?n=6,5,4&r=2'
q "$cli" phantom "$sphere&field=binary" -o "$work/u8.raw"
q "$cli" phantom "$sphere&type=i16" -o "$work/i16.raw"
q "$cli" phantom "$sphere&type=f32" -o "$work/f32.raw"
q "$cli" phantom "$sphere&field=binary" -o "$work/u8.nrrd"
q "$cli" phantom "$sphere&type=u16" -o "$work/u16.nrrd"
q "$cli" phantom "$sphere&type=f64" -o "$work/f64gz.nrrd" --compress
q "$cli" phantom "$sphere&field=binary" -o "$work/u8.mha"
q "$cli" phantom "$sphere&type=i32" -o "$work/i32z.mha" --compress
q "$cli" phantom "$sphere&field=binary&spacing=1,2,3" -o "$work/u8.nii"
q "$cli" phantom "$sphere&type=i16" -o "$work/i16.nii.gz"
gzip -n -c "$work/i16.raw" >"$work/i16.raw.gz"

# Meshes of every format, with and without normals.
mesh='phantom:sphere?n=6&r=2'
for ext in ply stl obj glb drc; do
  q "$cli" extract "$mesh" -q -o "$work/m.$ext"
done
q "$cli" extract "$mesh" -q --normals --method mt6 -o "$work/n.ply"
q "$cli" extract "$mesh" -q --normals --method bcc12 -o "$work/n.obj"
q "$cli" extract "$mesh" -q --draco off -o "$work/plain.glb"
q "$cli" extract "$mesh" -q --normals --space voxel -o "$work/n.drc"

# DICOM: a three-slice CT series.
q "$build/samples/make_dicom_series" 'phantom:sphere?n=4,4,3&r=1.5' "$work/dicom"
# DICOM Segmentations: 35-pixel frames (bits across bytes), fractional, label map, and overlapping
# segments on an oblique grid (two layers).
seg="$build/samples/make_dicom_seg"
q "$seg" 'phantom:nested?n=7,5,4' "$work/seg_binary.dcm"
q "$seg" --fractional 8 'phantom:nested?n=7,5,4' "$work/seg_fractional.dcm"
q "$seg" --labelmap 'phantom:boxes?n=7,5,4' "$work/seg_labelmap.dcm"
q "$seg" --overlap --rotate 20 'phantom:nested?n=7,5,4' "$work/seg_overlap.dcm"

# Images: PNG and TIFF slices, and a multi-page TIFF.
img="$build/tests/fuzz/fuzz_make_images"
q "$img" 'phantom:sphere?n=4,4,3&r=1.5&field=binary' "$work/p8_{}.png" uint8 1
q "$img" 'phantom:sphere?n=4,4,3&r=1.5&type=u16' "$work/p16_{}.png" uint16 1
q "$img" 'phantom:sphere?n=4,4,3&r=1.5&type=u16' "$work/t16_{}.tif" uint16 1
q "$img" 'phantom:sphere?n=4,4,3&r=1.5&type=f32' "$work/tf_{}.tif" float 1
q "$img" 'phantom:sphere?n=4,4,3&r=1.5&field=binary' "$work/rgb_{}.png" uint8 3
q "$img" 'phantom:sphere?n=4,4,3&r=1.5&type=u16' "$work/pages.tif" uint16 1 multipage

python3 - "$work" "$out" <<'PY'
import glob, os, struct, sys
work, out = sys.argv[1], sys.argv[2]
SEP = b"\n@@isoslab-fuzz-file@@\n"
def rd(name): return open(os.path.join(work, name), "rb").read()
def put(target, name, data): open(os.path.join(out, target, name), "wb").write(data)
def raw_opts(nx, ny, nz, vtype, flags=0, offset=0, spacing=0):
    return bytes([nx, ny, nz, vtype, flags, offset & 255, offset >> 8, spacing])

# raw: dims, type (u8 0, i16 3, f32 6), endianness, layouts, header bytes, spacing.
u8, i16, f32 = rd("u8.raw"), rd("i16.raw"), rd("f32.raw")
put("raw", "u8", raw_opts(6, 5, 4, 0) + u8)
put("raw", "i16", raw_opts(6, 5, 4, 3) + i16)
put("raw", "i16_big", raw_opts(6, 5, 4, 3, 1) + b"".join(i16[i + 1:i + 2] + i16[i:i + 1] for i in range(0, len(i16), 2)))
put("raw", "f32_offset", raw_opts(6, 5, 4, 6, 0, 7, 24) + b"HEADER!" + f32)
put("raw", "i16_gzip", raw_opts(6, 5, 4, 3) + rd("i16.raw.gz"))
slices = [u8[k * 30:(k + 1) * 30] for k in range(4)]
put("raw", "u8_folder", raw_opts(6, 5, 0, 0, 2) + SEP.join(slices))
put("raw", "u8_pattern", raw_opts(6, 5, 0, 0, 4) + SEP.join(slices))

# volume: selector = extension index + 8 * (channel + 1) + 32 * xform.
for name, sel in [("u8.nrrd", 0), ("u16.nrrd", 0), ("f64gz.nrrd", 0), ("u8.mha", 1), ("i32z.mha", 1),
                  ("u8.nii", 2), ("i16.nii.gz", 3)]:
    put("volume", name.replace(".", "_"), bytes([sel]) + rd(name))
put("volume", "u8_nii_qform", bytes([2 + 64]) + rd("u8.nii"))
nrrd = rd("u16.nrrd")
head, data = nrrd.split(b"\n\n", 1)
put("volume", "u16_nhdr", bytes([4]) + head + b"\ndata file: v.raw\n" + SEP + data)
mha = rd("u8.mha")
at = mha.index(b"ElementDataFile = LOCAL\n")
put("volume", "u8_mhd", bytes([5]) + mha[:at] + b"ElementDataFile = v.raw\n" + SEP + mha[at + 24:])
nii = rd("u8.nii")
hdr = bytearray(nii[:348])
hdr[344:348] = b"ni1\0"
hdr[108:112] = struct.pack("<f", 0.0)
put("volume", "u8_hdr_img", bytes([6]) + bytes(hdr) + SEP + nii[352:])

# dicom: selector bit 0 = a series.
files = sorted(glob.glob(os.path.join(work, "dicom", "*")))
put("dicom", "file", bytes([0]) + open(files[0], "rb").read())
put("dicom", "series", bytes([1]) + SEP.join(open(f, "rb").read() for f in files))
for name in ("binary", "fractional", "labelmap"):
    put("dicom", "seg_" + name, bytes([0]) + rd("seg_%s.dcm" % name))
put("dicom", "seg_overlap_layer0", bytes([8]) + rd("seg_overlap.dcm"))  # --channel 0

# image_stack: selector bit 0 = .tif, bits 1-2 the layout (0 folder, 1 list, 2 pattern, 3 one file).
def stack(prefix, ext):
    return SEP.join(open(f, "rb").read() for f in sorted(glob.glob(os.path.join(work, prefix + "_*." + ext))))
put("image_stack", "png8_folder", bytes([0]) + stack("p8", "png"))
put("image_stack", "png16_list", bytes([2]) + stack("p16", "png"))
put("image_stack", "tif16_pattern", bytes([1 + 4]) + stack("t16", "tif"))
put("image_stack", "tif_float_folder", bytes([1]) + stack("tf", "tif"))
put("image_stack", "png_rgb_channel", bytes([2 + 8]) + stack("rgb", "png"))
put("image_stack", "tif_multipage", bytes([1 + 6]) + rd("pages.tif"))

# mesh: selector = input extension index + 5 * output (5: no decode).
ext = {"ply": 0, "stl": 1, "obj": 2, "glb": 3, "drc": 4}
for i, (name, o) in enumerate([("m.ply", 1), ("m.stl", 2), ("m.obj", 3), ("m.glb", 0), ("m.drc", 2),
                               ("n.ply", 4), ("n.obj", 0), ("plain.glb", 5), ("n.drc", 0)]):
    put("mesh", name.replace(".", "_"), bytes([ext[name.split(".")[1]] + 5 * o]) + rd(name))

# extract: dims, flags (method, normals, threads, frame), iso, voxels (b - 128) / 4.
def volume(n, f):
    return bytes(f(i, j, k) for k in range(n) for j in range(n) for i in range(n))
ball = volume(6, lambda i, j, k: 128 + 40 - 4 * ((i - 2.5) ** 2 + (j - 2.5) ** 2 + (k - 2.5) ** 2).__int__())
saddle = volume(5, lambda i, j, k: 128 + (4 if (i + j + k) % 2 else -4))
special = volume(4, lambda i, j, k: [255, 254, 253, 252, 251, 250, 128, 140][(i + 2 * j + 3 * k) % 8])
for m in range(6):  # the method index: bits 0-1 and 6 of the flags
    bits = (m & 3) | (m & 4) << 4
    put("extract", f"ball_m{m}", bytes([4, 4, 4, bits | 4 | 8, 128 + 20]) + ball)
    put("extract", f"saddle_m{m}", bytes([3, 3, 3, bits | 16, 128]) + saddle)
    put("extract", f"special_m{m}", bytes([2, 2, 2, bits | 32 | 8, 1]) + special)
# --close-boundary (bit 7) with every method, on the ball cut by the volume's faces.
for m in range(6):
    put("extract", f"capped_m{m}", bytes([4, 4, 4, (m & 3) | (m & 4) << 4 | 4 | 8 | 128, 128 + 20]) + ball)
# mc33 (method 5) on an 8^3 field of few levels around iso 0: many ambiguous faces and tunnels.
levels = [100, 156, 120, 136, 128, 129, 127]
put("extract", "mc33_saddles", bytes([6, 6, 6, 1 | 64 | 8, 128]) +
    volume(8, lambda i, j, k: levels[(i * 7 + j * 13 + k * 29 + i * j * k) % 7]))
put("extract", "ball_frames", bytes([4, 4, 4, 1 | 48, 0]) + ball)
put("extract", "ball_double_iso", bytes([4, 4, 4, 3, 3]) + struct.pack("<d", 5.0000001) + ball)
PY
du -sh "$out"; for d in "$out"/*; do echo "$(basename "$d"): $(ls "$d" | wc -l) files, $(du -sb "$d" | cut -f1) bytes"; done
