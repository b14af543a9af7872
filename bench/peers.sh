#!/usr/bin/env bash
# The peer comparison (bench/peers.py): installs Debian's python3-vtk9 and python3-skimage when
# missing, builds Release, and prints the table that docs/performance.md keeps.
# Usage: bench/peers.sh [--runs N]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
missing=()
for p in python3-vtk9 python3-skimage; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""; [ "$(id -u)" -ne 0 ] && sudo=sudo
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target isoslab isoslab_extract_only
exec /usr/bin/python3 bench/peers.py build "$@"
