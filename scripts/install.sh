#!/usr/bin/env bash
# Installs what is missing, builds Release and installs isoslab under PREFIX (default /usr/local):
# the program, the libraries and headers with their CMake files, and the Python package under
# PREFIX/lib/python3.X/dist-packages, which Debian's python3 reads for /usr/local and /usr.
# Usage: bash scripts/install.sh [PREFIX]
set -euo pipefail
cd "$(dirname "$0")/.."
prefix=${1:-/usr/local}
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$prefix" >/dev/null
cmake --build build -j "$(nproc)"
cmake --install build >/dev/null
echo "install: isoslab $("$prefix/bin/isoslab" --version | awk '{print $NF}') in $prefix"
