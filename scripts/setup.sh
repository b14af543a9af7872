#!/usr/bin/env bash
# Installs isoslab's Debian 12 build dependencies when any is missing. Needs root (or sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libgtest-dev libgmock-dev libbenchmark-dev libtinyobjloader-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev zlib1g-dev libpng-dev
  libdcmtk-dev libopenjp2-7-dev libdraco-dev libeigen3-dev draco libmeshoptimizer-dev libisal-dev
  python3-matplotlib libopenimageio-dev fonts-dejavu-core
  python3-vtk9
  # Peers for bench/topology.py (scikit-image's Lewiner MC33, the DICOM read by pydicom).
  python3-skimage python3-pydicom
  clang libclang-rt-14-dev
  # isoslab extract under mpirun (issue 20).
  libopenmpi-dev openmpi-bin
  # The Python module and its tests (issue 21).
  pybind11-dev python3-dev python3-numpy python3-pytest python3-scipy
  # extract()'s progress bar on a terminal (issue 34).
  python3-tqdm
  # 3MF output through lib3mf 1.8, and PrusaSlicer's command line to check printable outputs (issue 37).
  lib3mf-dev prusa-slicer
  # The Debian package and its checks (issue 22): cpack's dpkg-shlibdeps needs file; the man page.
  dpkg-dev file help2man lintian
  # A compiler cache for every build of scripts/test.sh (CMakeLists.txt uses it when found).
  ccache
  chromium
)
# Node.js runs the real glTF clients in the tests; use the machine's own when it has one.
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
# A real MRI brain template for the demo (scripts/demo.sh falls back to a phantom without it).
packages+=(mricron-data)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "setup: installing ${missing[*]}" >&2
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
