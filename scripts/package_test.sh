#!/usr/bin/env bash
# The installed library and the Debian package, as their users meet them (issue 22). Needs root
# for its last part (dpkg -i). Run by scripts/test.sh after the Release suite.
#
#   bash scripts/package_test.sh [BUILD_DIR]     (default build; configured with -DCMAKE_INSTALL_PREFIX=/usr)
#
# Not as root, it fails unless ISOSLAB_SKIP_DPKG=1 says to leave out the dpkg -i part.
#
# 1. cmake --install into a temporary prefix. samples/, configured as a project of its own, finds
#    the library with find_package(isoslab) alone, three times: no C++ standard set (the target
#    asks for C++20), CMAKE_CXX_STANDARD 20, and CMAKE_CXX_STANDARD 17 (raised to 20). The first
#    build also compiles every installed header on its own. extract_sphere runs, and its counts
#    are checked against the installed program's.
# 2. A consumer built with pkg-config --cflags --libs isoslab runs.
# 3. The installed Python package, found by PYTHONPATH alone, imports and runs the installed
#    program and the OpenImageIO module (a TIFF stack).
# 4. cpack makes isoslab_<version>_amd64.deb; lintian must report no error. The package is
#    installed with dpkg -i and used with the build folder moved away (the program, the Python
#    package, and libisoslab.so, each loading the OpenImageIO module), then purged.
set -euo pipefail
cd "$(dirname "$0")/.."
src=$PWD
build=$(cd "${1:-build}" && pwd)
version=$("$build/cli/isoslab" --version | awk '{print $NF}')
hide=$build.hidden-by-package-test
if [ -e "$hide" ]; then
  echo "package_test: $hide exists (left by a killed run?); move it back or remove it first" >&2
  exit 1
fi
if ! grep -qE '^CMAKE_INSTALL_PREFIX:PATH=/usr/?$' "$build/CMakeCache.txt"; then
  echo "package_test: $build is not configured for /usr (cmake -DCMAKE_INSTALL_PREFIX=/usr), as the .deb needs" >&2
  exit 1
fi
command -v lintian >/dev/null || { echo "package_test: lintian is missing (scripts/setup.sh installs it)" >&2; exit 1; }
if [ "$(id -u)" -ne 0 ] && [ "${ISOSLAB_SKIP_DPKG:-0}" != 1 ]; then
  echo "package_test: dpkg -i needs root (ISOSLAB_SKIP_DPKG=1 leaves that part out)" >&2
  exit 1
fi
work=$(mktemp -d /tmp/isoslab-package.XXXXXX)
prefix=$work/prefix
hidden=""
installed=0
cleanup() {
  if [ -n "$hidden" ] && [ -d "$hidden" ]; then mv "$hidden" "$build"; fi
  if [ "$installed" -eq 1 ]; then dpkg -P isoslab >/dev/null 2>&1 || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "package_test: $*" >&2
  exit 1
}

# The reference: the installed program's own count for the sample's sphere (radius 20, iso 800).
check_sphere() {  # check_sphere PROGRAM_OUTPUT PLY ISOSLAB
  local line=$1 ply=$2 program=$3
  [[ $line =~ ^([0-9]+)\ triangles,.*Euler\ characteristic\ 2$ ]] || fail "extract_sphere printed '$line'"
  local triangles=${BASH_REMATCH[1]}
  local measured
  measured=$("$program" metrics "$ply" | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["triangles"])')
  [ "$triangles" = "$measured" ] || fail "extract_sphere counted $triangles triangles, isoslab metrics $measured"
  "$program" extract 'phantom:sphere?n=64&r=20' --iso 800 -o "$work/ref.ply" --report "$work/ref.json" -q
  local expected
  expected=$(/usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["triangles"])' "$work/ref.json")
  [ "$triangles" = "$expected" ] || fail "extract_sphere made $triangles triangles, isoslab extract $expected"
}

echo "package_test: cmake --install into $prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
libdir=$(dirname "$(find "$prefix" -name 'libisoslab.so' | head -1)")
program=$prefix/bin/isoslab

n=0
for standard in "" 20 17; do
  n=$((n + 1))
  args=(-DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release)
  [ -n "$standard" ] && args+=(-DCMAKE_CXX_STANDARD="$standard")
  [ "$n" -eq 1 ] && args+=(-DISOSLAB_SAMPLES_CHECK_HEADERS=ON)
  cmake -S "$src/samples" -B "$work/consumer$n" -G Ninja "${args[@]}" >"$work/configure.log" 2>&1 ||
    { cat "$work/configure.log" >&2; fail "samples/ did not configure against the installed package (C++ standard '${standard:-unset}')"; }
  cmake --build "$work/consumer$n" -j "$(nproc)" >"$work/build.log" 2>&1 ||
    { tail -40 "$work/build.log" >&2; fail "samples/ did not build against the installed package (C++ standard '${standard:-unset}')"; }
  out=$("$work/consumer$n/extract_sphere" "$work/sphere$n.ply")
  check_sphere "$out" "$work/sphere$n.ply" "$program"
  echo "package_test: find_package consumer (C++ standard ${standard:-not set}): $out"
done

export PKG_CONFIG_PATH=$libdir/pkgconfig
# The README's example programs (the C++ blocks of "Using the library"), built through pkg-config:
# the job (runExtract), then the parts underneath. Each must write what isoslab extract writes.
readme_block() {
  awk -v want="$1" '/^## Using the library/ {on = 1} on && /^```cpp/ {n++; if (n == want) {code = 1}; next}
    code && /^```/ {exit} code {print}' "$src/README.md"
}
for block in 1 2; do
  readme_block "$block" >"$work/readme_app$block.cpp"
  [ -s "$work/readme_app$block.cpp" ] || fail "README.md has no C++ example $block under 'Using the library'"
  # shellcheck disable=SC2046 # the flags are words
  g++ -std=c++20 "$work/readme_app$block.cpp" -o "$work/readme_app$block" $(pkg-config --cflags --libs isoslab) \
    -Wl,-rpath,"$(pkg-config --variable=libdir isoslab)" || fail "the README's example $block did not build"
done
"$work/readme_app1" 'phantom:sphere?n=32' "$work/readme1.glb" >/dev/null || fail "the README's job example failed"
"$program" extract 'phantom:sphere?n=32' --iso bone --close-boundary --keep-largest 1 --smooth 10 \
  -o "$work/readme1_ref.glb" -q
cmp -s "$work/readme1.glb" "$work/readme1_ref.glb" || fail "the README's job example wrote another mesh than isoslab extract"
"$work/readme_app2" 'phantom:sphere?n=32' 900 "$work/readme2.ply" || fail "the README's example failed"
"$program" extract 'phantom:sphere?n=32' --iso 900 -o "$work/readme2_ref.ply" -q
cmp -s "$work/readme2.ply" "$work/readme2_ref.ply" || fail "the README's example wrote another mesh than isoslab extract"
echo "package_test: the README's example programs write the meshes isoslab extract writes"
# shellcheck disable=SC2046 # the flags are words
g++ -std=c++20 -O1 "$src/samples/extract_sphere.cpp" -o "$work/pc_sphere" $(pkg-config --cflags --libs isoslab) \
  -Wl,-rpath,"$(pkg-config --variable=libdir isoslab)" || fail "the pkg-config consumer did not build"
out=$("$work/pc_sphere" "$work/pc.ply")
check_sphere "$out" "$work/pc.ply" "$program"
echo "package_test: pkg-config consumer ($(pkg-config --modversion isoslab)): $out"
unset PKG_CONFIG_PATH

# A TIFF stack (read through the OpenImageIO module) for the installed program and Python package.
mkdir "$work/stack"
/usr/bin/python3 - "$work/stack" <<'EOF'
import sys
import numpy as np
from PIL import Image
z, y, x = np.mgrid[0:12, 0:20, 0:24]
ball = (1000 * ((x - 11.5) ** 2 + (y - 9.5) ** 2 + (z - 5.5) ** 2 < 25)).astype(np.uint16)
for k, s in enumerate(ball):
    Image.fromarray(s).save(f"{sys.argv[1]}/slice{k:02d}.tif")
EOF
# A DICOM series of the same kind of sphere, written by the build's sample (DCMTK), for the DICOM module.
"$build/samples/make_dicom_series" 'phantom:sphere?n=16&r=5' "$work/dicom" >/dev/null ||
  fail "make_dicom_series could not write a DICOM series"
check_installed() {  # check_installed PROGRAM PYTHONPATH: the program, its modules, the Python package
  local prog=$1 pythonpath=$2
  (cd "$work" && "$prog" extract "$work/stack" --iso 500 -o "$work/stack.glb" -q) ||
    fail "$prog could not read a TIFF stack (the OpenImageIO module)"
  (cd "$work" && env -u ISOSLAB_DICOM_MODULE "$prog" extract "$work/dicom" --iso 950 -o "$work/dicom.ply" -q) ||
    fail "$prog could not read a DICOM series (the DICOM module)"
  (cd "$work" && env -u ISOSLAB_3MF_MODULE "$prog" extract 'phantom:sphere?n=16&r=5' -o "$work/sphere.3mf" -q &&
    [ -s "$work/sphere.3mf" ]) || fail "$prog could not write a 3MF file (the 3MF module)"
  env -u ISOSLAB_PROGRAM -u ISOSLAB_OIIO_MODULE -u ISOSLAB_DICOM_MODULE PYTHONPATH="$pythonpath" /usr/bin/python3 -B - "$work" "$version" <<'EOF' ||
import os, sys
import isoslab
work, version = sys.argv[1], sys.argv[2]
assert isoslab.__version__ == version, isoslab.__version__
dicom = isoslab.extract(os.path.join(work, "dicom"), os.path.join(work, "py-dicom.ply"), iso=950)
assert dicom["triangles"] > 0, dicom
report = isoslab.extract(os.path.join(work, "stack"), os.path.join(work, "py.ply"), iso=500)
slices = list(isoslab.iter_slices(os.path.join(work, "stack")))
assert len(slices) == 12 and slices[0][0].shape == (20, 24), (len(slices), slices[0][0].shape)
assert report["triangles"] > 0
print(f"package_test: Python package {isoslab.__version__} from {os.path.dirname(isoslab.__file__)}: "
      f"{report['triangles']} triangles from the TIFF stack")
EOF
    fail "the installed Python package failed"
}
check_installed "$program" "$(dirname "$(find "$prefix" -name __init__.py -path '*isoslab*' | head -1)")/.."

# The Debian package.
(cd "$build" && cpack -G DEB >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log" >&2; fail "cpack -G DEB failed"; }
deb=$build/isoslab_${version}_amd64.deb
[ -f "$deb" ] || fail "cpack made no $deb"
echo "package_test: $(basename "$deb"): $(dpkg-deb -f "$deb" Depends | tr -d '\n')"
# lintian exits 1 when it reports an error, and 2 when it could not check the package.
status=0
lintian --tag-display-limit 0 "$deb" >"$work/lintian.log" 2>&1 || status=$?
grep -v "running with root privileges" "$work/lintian.log" | sed 's/^/package_test: lintian: /' || true
if [ "$status" -ne 0 ] || grep -q '^E: ' "$work/lintian.log"; then
  fail "lintian reports errors on $(basename "$deb") (exit status $status)"
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "package_test: not root; dpkg -i left out (ISOSLAB_SKIP_DPKG=1)"
  exit 0
fi
if dpkg-query -W -f='${Status}' isoslab 2>/dev/null | grep -q "install ok installed"; then
  fail "a package isoslab is installed already; remove it first (dpkg -P isoslab)"
fi
cp "$deb" "$work/"
installed=1
dpkg -i "$work/$(basename "$deb")" >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log" >&2; fail "dpkg -i failed"; }
hidden=$hide
mv "$build" "$hidden"
(cd "$work" && env -u ISOSLAB_OIIO_MODULE /usr/bin/isoslab --version >/dev/null &&
  /usr/bin/isoslab extract 'phantom:sphere?n=32' --iso 900 -o s.glb -q && [ -s s.glb ]) ||
  fail "the installed /usr/bin/isoslab failed"
dpkg -L isoslab | grep -qx /usr/share/man/man1/isoslab.1.gz || fail "the package has no man page"
# (PYTHONPATH so that a package installed under /usr/local does not hide this one)
check_installed /usr/bin/isoslab /usr/lib/python3/dist-packages
# The library reads the TIFF stack through the module it finds beside itself.
cat >"$work/stack_info.cpp" <<'EOF'
#include <cstdio>

#include "io/open_source.h"

int main(int, char** argv) {
  const auto source = isoslab::openSource(argv[1], {});
  const auto& d = source->info().dims;
  std::printf("%lld %lld %lld\n", static_cast<long long>(d[0]), static_cast<long long>(d[1]), static_cast<long long>(d[2]));
}
EOF
# Debian's pkg-config folders only: an isoslab under /usr/local must not stand in for the package.
# shellcheck disable=SC2046 # the flags are words
g++ -std=c++20 "$work/stack_info.cpp" -o "$work/stack_info" \
  $(PKG_CONFIG_PATH="" PKG_CONFIG_LIBDIR=/usr/lib/x86_64-linux-gnu/pkgconfig:/usr/share/pkgconfig pkg-config --cflags --libs isoslab) \
  -Wl,-rpath,/usr/lib/x86_64-linux-gnu || fail "a pkg-config consumer of the installed package did not build"
ldd "$work/stack_info" | grep -q "libisoslab.so.0.1 => /usr/lib/x86_64-linux-gnu/libisoslab.so.0.1" ||
  fail "the consumer does not use the package's libisoslab.so: $(ldd "$work/stack_info" | grep isoslab)"
[ "$(env -u ISOSLAB_OIIO_MODULE "$work/stack_info" "$work/stack")" = "24 20 12" ] ||
  fail "libisoslab.so could not read a TIFF stack (the OpenImageIO module)"
mv "$hidden" "$build"
hidden=""
dpkg -P isoslab >/dev/null
installed=0
echo "package_test: the .deb installs with dpkg -i, runs without the build folder, and purges cleanly"
