#!/bin/bash
# Per-method extraction times of two builds of bench/isoslab_extract_only, alternating, in paired
# rounds (the machine's speed drifts): prints "round volume build method median_seconds" lines.
# Usage: bench/per_method_pairs.sh OLD_EXTRACT_ONLY NEW_EXTRACT_ONLY [DIR]
# DIR holds brain.nii, phantom.nii and engine.nii (bench/peers.py writes them the same way).
set -euo pipefail
old=$1 new=$2 dir=${3:-/tmp}
for r in 1 2 3; do
  for v in "brain 50" "phantom 300" "engine 90"; do
    set -- $v
    [ -f "$dir/$1.nii" ] || continue
    for b in old new; do
      exe=$old; [ $b = new ] && exe=$new
      for m in mc mt6 bcc12; do
        echo -n "$r $1 $b $m "
        "$exe" "$dir/$1.nii" --iso "$2" --method $m --runs 5 |
          python3 -c "import json,sys;print(json.load(sys.stdin)['median_seconds'])"
      done
    done
  done
done
