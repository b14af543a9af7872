#!/usr/bin/env bash
# Compares the output bytes of two isoslab builds: every method, 1 and 3 threads, every mesh
# format, on a noisy phantom and (when ../shared/data is present) on the Philips head CT.
#
#   scripts/check_bytes.sh REFERENCE_ISOSLAB NEW_ISOSLAB
#
# A refactor must leave the output unchanged: this prints one line per run and exits 1 if any
# pair of files differs. Build the reference from the commit before the change, e.g.
#   git worktree add /tmp/ref <commit> && cmake -S /tmp/ref -B /tmp/ref/build -G Ninja \
#     -DISOSLAB_BUILD_TESTS=OFF -DISOSLAB_BUILD_BENCH=OFF && cmake --build /tmp/ref/build --target isoslab
set -euo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 REFERENCE_ISOSLAB NEW_ISOSLAB" >&2
  exit 2
fi
ref=$1
new=$2
here="$(cd "$(dirname "$0")/.." && pwd)"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

inputs=("phantom:head?n=40,36,32&seed=3&noise=0.05")
isos=("")
philips="$here/../shared/data/ct-philips-head"
if [ -d "$philips" ]; then
  inputs+=("$philips")
  isos+=("--iso 350")
fi

runs=0
differ=0
# CHECK_BYTES_OPTIONS_ONLY=1: only the option runs below (the method runs take minutes).
[ "${CHECK_BYTES_OPTIONS_ONLY:-0}" = 1 ] && inputs=()
for k in "${!inputs[@]}"; do
  input=${inputs[$k]}
  for method in mc mt5 mt6 bcc12 mt24 mc33; do
    for threads in 1 3; do
      for format in ply stl obj drc glb; do
        extra=(--method "$method" --threads "$threads" -q)
        [ "$format" = ply ] || [ "$format" = obj ] && extra+=(--normals)
        # shellcheck disable=SC2206
        iso=(${isos[$k]})
        "$ref" extract "$input" "${iso[@]}" "${extra[@]}" -o "$work/ref.$format"
        "$new" extract "$input" "${iso[@]}" "${extra[@]}" -o "$work/new.$format"
        runs=$((runs + 1))
        if cmp -s "$work/ref.$format" "$work/new.$format"; then
          echo "same     $(basename "$input") $method threads=$threads .$format ($(stat -c %s "$work/new.$format") bytes)"
        else
          echo "DIFFERS  $(basename "$input") $method threads=$threads .$format"
          differ=$((differ + 1))
        fi
      done
    done
  done
done
# The options around the extraction, on the phantom: the mesh, stderr (without --quiet the
# summary's time is masked), the exit status and the report (its times and memory masked).
mask_report() {
  /usr/bin/python3 - "$1" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except OSError:
    print("no report"); sys.exit()
for key in ("seconds", "peak_rss_mib", "generator"):
    r.pop(key, None)
print(json.dumps(r, sort_keys=False))
PY
}
phantom="phantom:head?n=40,36,32&seed=3&noise=0.05"
option_runs=(
  "--iso 0.5 --report @R@"
  "--iso auto --report @R@ --normals"
  "--iso bone --report @R@"
  "--report @R@"
  "--iso 0.5 --close-boundary --keep-largest 1 --report @R@"
  "--iso 0.5 --min-triangles 50 --component-measure volume --report @R@"
  "--iso 0.5 --seed 20,18,16 --report @R@"
  "--iso 0.5 --roi 2,2,2,30,30,30 --report @R@"
  "--iso 0.5 --roi -5,-5,-5,100,100,100 --report @R@"
  "--iso 0.5 --roi 0,0,0,10,10,10 --roi-space physical --report @R@"
  "--iso 0.5 --smooth 10 --normals --report @R@"
  "--iso 0.5 --smooth 6 --smooth-method taubin --smooth-faces lock --report @R@"
  "--iso 0.5 --decimate 0.3 --report @R@"
  "--iso 0.5 --max-error 0.5 --close-boundary --report @R@"
  "--iso 0.5 --sphere 20,18,16,10 --report @R@ --space voxel"
  "--iso 0.5 --space ras --preview @P@ --report @R@"
  "--iso 99 --report @R@"
  "--iso -99 --report @R@"
  "--iso 0.5 --pass-band 3 --smooth 4"
  "--iso 0.5 --report @OUT@"
  "--iso 0.5 --roi 0,0,0,10,10,0.5"
)
for opts in "${option_runs[@]}"; do
  for side in ref new; do
    bin=$ref
    [ "$side" = new ] && bin=$new
    # shellcheck disable=SC2206
    args=(${opts//@R@/$work/$side.json})
    args=("${args[@]//@P@/$work/$side.png}")
    args=("${args[@]//@OUT@/$work/$side.ply}")
    rm -f "$work/$side.json" "$work/$side.png" "$work/$side.ply"
    set +e
    "$bin" extract "$phantom" "${args[@]}" -o "$work/$side.ply" 2>"$work/$side.err"
    echo "exit $?" >>"$work/$side.err"
    set -e
    sed -i -E "s/, [0-9]+\.[0-9]+ s -> /, T s -> /; s#$work/$side#OUT#g" "$work/$side.err"
    mask_report "$work/$side.json" | sed "s#$work/$side#OUT#g" >"$work/$side.masked"
  done
  runs=$((runs + 1))
  same_mesh() { if [ -f "$work/ref.ply" ]; then cmp -s "$work/ref.ply" "$work/new.ply"; else [ ! -f "$work/new.ply" ]; fi; }
  if same_mesh && cmp -s "$work/ref.err" "$work/new.err" &&
    cmp -s "$work/ref.masked" "$work/new.masked" && { [ ! -f "$work/ref.png" ] || cmp -s "$work/ref.png" "$work/new.png"; }; then
    echo "same     options: $opts"
  else
    echo "DIFFERS  options: $opts"
    diff "$work/ref.err" "$work/new.err" | head -5 >&2 || true
    diff "$work/ref.masked" "$work/new.masked" | head -5 >&2 || true
    differ=$((differ + 1))
  fi
done
echo "check_bytes: $runs runs, $differ differ"
[ "$differ" -eq 0 ]
