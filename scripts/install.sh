#!/usr/bin/env bash
# Installs what is missing, builds Release and installs isoslab under PREFIX (default /usr/local):
# the program and its man page, libisoslab.so with its headers, CMake and pkg-config files, the
# OpenImageIO module, and the Python package where Debian's python3 reads it
# (PREFIX/lib/python3.X/dist-packages; /usr/lib/python3/dist-packages for /usr).
# For a Debian package instead: scripts/package_test.sh, or cpack -G DEB in a build for /usr.
# Usage: bash scripts/install.sh [PREFIX]
set -euo pipefail
cd "$(dirname "$0")/.."
prefix=${1:-/usr/local}
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$prefix" >/dev/null
cmake --build build -j "$(nproc)"
cmake --install build >/dev/null
# The dynamic linker's cache, which it reads for folders such as /usr/local/lib/x86_64-linux-gnu.
if [ "$(id -u)" -eq 0 ]; then ldconfig; fi
echo "install: isoslab $("$prefix/bin/isoslab" --version | awk '{print $NF}') in $prefix"
