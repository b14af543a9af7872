#!/usr/bin/env bash
# The main job: installs what is missing, builds Release, and extracts surfaces into out/:
# - the MRI brain template ch2better (Debian's mricron-data; Colin Holmes' brain, as distributed
#   with MRIcron by Chris Rorden) at iso 50, as PLY and as a Draco-compressed glTF (.glb);
# - the built-in noisy CT-like head phantom (160 x 160 x 140 int16) at the skin (-400 HU) and the
#   bone (+300 HU), which needs no file at all;
# each with a rendered preview, out/*.png.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target isoslab
# three.js for the viewer page (isoslab view), vendored from npm into build/npm; never a CDN.
if [ ! -d build/npm/node_modules/three ]; then
  mkdir -p build/npm && cp tests/encode/js/package.json build/npm/
  (cd build/npm && npm install --no-audit --no-fund --loglevel=error >/dev/null) ||
    echo "demo: npm install failed; the viewer pages are skipped" >&2
fi
view() {
  if [ -d build/npm/node_modules/three ]; then ./build/cli/isoslab view "$@"; fi
}

mkdir -p out
brain=/usr/share/mricron/templates/ch2better.nii.gz
if [ -f "$brain" ]; then
  ./build/cli/isoslab extract "$brain" --iso 50 --normals -o out/brain.ply --report out/brain.json \
    --preview out/brain.png --preview-view left
  ./build/cli/isoslab extract "$brain" --iso 50 --normals -o out/brain.glb --report out/brain-glb.json
  view out/brain.glb --report out/brain-glb.json
else
  echo "demo: $brain is not installed (Debian package mricron-data); using the phantom only" >&2
fi
input='phantom:head?n=160,160,140'
./build/cli/isoslab extract "$input" --iso -400 --normals -o out/head-skin.ply --report out/head-skin.json \
  --preview out/head-skin.png
./build/cli/isoslab extract "$input" --iso 300 --method mt6 --normals -o out/head-bone.ply --report out/head-bone.json \
  --preview out/head-bone.png --preview-view iso
echo "demo: meshes in out/ (open the .ply or .glb files in any mesh viewer); reports in out/*.json"
./build/cli/isoslab extract "$input" --iso -400 --normals -o out/head-skin.glb --report out/head-skin-glb.json -q
view out/head-skin.glb --report out/head-skin-glb.json
echo "demo: pictures: $(ls out/*.png | tr '\n' ' ')"
if ls out/*.html >/dev/null 2>&1; then
  echo "demo: viewer pages (open in a browser): $(ls out/*.html | tr '\n' ' ')"
fi
