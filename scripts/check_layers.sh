#!/usr/bin/env bash
# Checks the module graph (docs/design.md, Module map): which project folders each module may
# include, which isoslab libraries each may link, and that core/ and extract/ use no third-party
# library. Prints every violation and exits 1 if there is one.
set -euo pipefail
cd "$(dirname "$0")/.."

# module: the project folders its sources may include (besides its own).
declare -A allowed=(
  [core]=""
  [io]="core"
  [extract]="core"
  [encode]="core"
  [stream]="io extract core"
  [metrics]="stream io extract core"
  [render]="core"
  [process]="core"
  [job]="process render metrics encode stream io extract core"
)
# Libraries that core/ and extract/ must not use: the kernels build with the compiler alone.
thirdParty='^#include <(fmt|nlohmann|draco|dcmtk|OpenImageIO|openjpeg|zlib\.h|CLI|Eigen)'

bad=0
for module in "${!allowed[@]}"; do
  [ -d "$module" ] || continue
  while IFS= read -r line; do
    file=${line%%:*}
    target=$(sed -E 's/.*#include "([a-z_]+)\/.*/\1/' <<<"$line")
    [ "$target" = "$module" ] && continue
    case " ${allowed[$module]} " in
      *" $target "*) ;;
      *)
        echo "check_layers: $file includes $target/, which $module/ may not use (${line#*:})"
        bad=1
        ;;
    esac
  done < <(grep -HnE '^#include "[a-z_]+/' "$module"/*.h "$module"/*.cpp 2>/dev/null | sed -E 's/^([^:]+):[0-9]+:/\1:/')
  # Link rules: the isoslab libraries named in the module's target_link_libraries.
  if [ -f "$module/CMakeLists.txt" ]; then
    links=$(awk '/target_link_libraries\(/ {on = 1} on {print} /\)/ {on = 0}' "$module/CMakeLists.txt" |
      sed -E 's/target_link_libraries\([a-z_]+//')
    for lib in $(grep -oE 'isoslab_[a-z]+' <<<"$links" | sort -u); do
      dep=${lib#isoslab_}
      [ "$dep" = "$module" ] && continue
      case " ${allowed[$module]} " in
        *" $dep "*) ;;
        *)
          echo "check_layers: $module/CMakeLists.txt links $lib, which $module/ may not use"
          bad=1
          ;;
      esac
    done
  fi
done
for module in core extract render; do
  if grep -HnE "$thirdParty" "$module"/*.h "$module"/*.cpp; then
    echo "check_layers: $module/ uses a third-party library (above); it must build with the standard library alone"
    bad=1
  fi
done
if [ "$bad" -eq 0 ]; then echo "check_layers: the module graph follows the rules"; fi
exit "$bad"
