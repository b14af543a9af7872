#!/usr/bin/env bash
# deb_chroot_test.sh - install isoslab's .deb with apt-get into a fresh, minimal Debian 12 chroot
# (mmdebstrap) and use it: the program, its man page, the libraries, the Python package,
# pkg-config and the CMake files; then purge it and check that nothing is left. Not part of
# scripts/test.sh: it downloads about 200 MB of dependencies and takes about 6 minutes.
#
# Usage: sudo bash scripts/deb_chroot_test.sh [options] build/isoslab_0.1.0_amd64.deb WORKDIR
#
#   WORKDIR/chroot      the throw-away chroot (must not exist yet; deleted at the end)
#   WORKDIR/apt-cache   .deb cache reused between runs (both for mmdebstrap and for apt-get
#                       inside the chroot), so a second run downloads almost nothing
#   log                 WORKDIR/chroot_test.log unless -l is given (everything is also on stdout)
#
# Options:
#   -s SUITE     Debian suite (default: bookworm)
#   -m MIRROR    mirror URL or an apt sources file (default: the host's
#                /etc/apt/sources.list.d/debian.sources if it exists, else http://deb.debian.org/debian)
#   -v VARIANT   mmdebstrap variant (default: apt)
#   -l LOGFILE   log file (default: WORKDIR/chroot_test.log)
#   -k           keep the chroot afterwards (mounts are still undone)
#   -n           no package cache (always download)
#
# Needs root, mmdebstrap (apt-get install --no-install-recommends mmdebstrap) and network
# access to the mirror. Exit status: 0 if every check passed, 1 if any check failed,
# 2 for usage errors; a failing setup step (mmdebstrap, apt-get install) aborts the run with its
# own non-zero status.
set -euo pipefail

SUITE=bookworm
VARIANT=apt
MIRROR=
LOG=
KEEP=0
CACHE_ON=1

usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 2; }

while getopts "s:m:v:l:knh" opt; do
  case $opt in
    s) SUITE=$OPTARG ;;
    m) MIRROR=$OPTARG ;;
    v) VARIANT=$OPTARG ;;
    l) LOG=$OPTARG ;;
    k) KEEP=1 ;;
    n) CACHE_ON=0 ;;
    *) usage ;;
  esac
done
shift $((OPTIND - 1))
[[ $# -eq 2 ]] || usage

DEB=$(readlink -f "$1")
WORK=$(readlink -f "$2")
CHROOT=$WORK/chroot
CACHE=$WORK/apt-cache
LOG=${LOG:-$WORK/chroot_test.log}
if [[ -z $MIRROR ]]; then
  if [[ -f /etc/apt/sources.list.d/debian.sources ]]; then
    MIRROR=/etc/apt/sources.list.d/debian.sources
  else
    MIRROR=http://deb.debian.org/debian
  fi
fi

[[ $EUID -eq 0 ]] || { echo "error: must run as root" >&2; exit 2; }
[[ -f $DEB ]] || { echo "error: no such file: $DEB" >&2; exit 2; }
command -v mmdebstrap >/dev/null || { echo "error: mmdebstrap not installed" >&2; exit 2; }
[[ ! -e $CHROOT ]] || { echo "error: $CHROOT already exists; remove it first" >&2; exit 2; }

PKG=$(dpkg-deb -f "$DEB" Package)
DEBNAME=$(basename "$DEB")
mkdir -p "$WORK"
[[ $CACHE_ON -eq 1 ]] && mkdir -p "$CACHE"
: > "$LOG"
exec > >(tee -a "$LOG") 2>&1
TEE_PID=$!

T0=$(date +%s)
FAILS=0
RESULTS=()

say()  { printf '\n==== %s ====\n' "$*"; }
note() { printf '%s\n' "$*"; }

# Mount points at or below $1.
mounts_under() { findmnt -rn -o TARGET | awk -v p="$1" '$0 == p || index($0, p "/") == 1'; }

# Undo every mount below the chroot (deepest first), then delete it unless -k.
cleanup() {
  local rc=$? m
  set +e
  if [[ -d $CHROOT ]]; then
    while read -r m; do
      [[ -n $m ]] || continue
      umount "$m" 2>/dev/null || umount -l "$m"
      echo "cleanup: unmounted $m"
    done < <(mounts_under "$CHROOT" | sort -r)
    if [[ -n $(mounts_under "$CHROOT") ]]; then
      echo "cleanup: WARNING something is still mounted under $CHROOT; not deleting it"
    elif [[ $KEEP -eq 0 ]]; then
      rm -rf --one-file-system "$CHROOT" && echo "cleanup: removed $CHROOT"
    else
      echo "cleanup: kept $CHROOT (-k)"
    fi
  fi
  echo "total time: $(( $(date +%s) - T0 )) s; exit status $rc"
  exec >&- 2>&-                    # close the pipe to tee, then let it flush
  wait "$TEE_PID" 2>/dev/null || true
  exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# Run a shell command inside the chroot with a clean environment.
in_chroot() {
  chroot "$CHROOT" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root \
    LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive /bin/bash -o pipefail -c "$1"
}

# check NAME EXPECT CMD: run CMD in /root/t in the chroot, show output and exit status;
# EXPECT is "ok" (must exit 0) or "fail" (must exit non-zero).
check() {
  local name=$1 expect=$2 cmd=$3 rc verdict
  printf '\n---- %s\n$ %s\n' "$name" "$cmd"
  set +e
  in_chroot "cd /root/t && $cmd"
  rc=$?
  set -e
  if { [[ $expect == ok ]] && [[ $rc -eq 0 ]]; } || { [[ $expect == fail ]] && [[ $rc -ne 0 ]]; }; then
    verdict=PASS
  else
    verdict=FAIL; FAILS=$((FAILS + 1))
  fi
  printf '[exit status %d, expected %s] %s\n' "$rc" "$expect" "$verdict"
  RESULTS+=("$(printf '%-4s rc=%-3d %s' "$verdict" "$rc" "$name")")
}

say "chroot test of $DEBNAME"
note "date:     $(date -u '+%F %T UTC')"
note "host:     $(sed -n 's/^PRETTY_NAME="\{0,1\}\([^"]*\)"\{0,1\}$/\1/p' /etc/os-release) $(dpkg --print-architecture), mmdebstrap $(dpkg-query -W -f='${Version}' mmdebstrap 2>/dev/null || echo '?')"
note "package:  $DEB ($PKG $(dpkg-deb -f "$DEB" Version), $(stat -c %s "$DEB") bytes)"
note "depends:  $(dpkg-deb -f "$DEB" Depends)"
note "recommends: $(dpkg-deb -f "$DEB" Recommends)"
note "chroot:   $CHROOT (suite $SUITE, variant $VARIANT, mirror $MIRROR)"
note "cache:    $([[ $CACHE_ON -eq 1 ]] && echo "$CACHE ($(find "$CACHE" -name '*.deb' | wc -l) .debs)" || echo off)"
note "log:      $LOG"

# ---------------------------------------------------------------- step 1: the chroot
say "1. mmdebstrap --variant=$VARIANT $SUITE $CHROOT $MIRROR"
MMARGS=(--variant="$VARIANT")
if [[ $CACHE_ON -eq 1 ]]; then
  # Recipe from mmdebstrap(1): seed the chroot's archive cache and copy it back out afterwards.
  # shellcheck disable=SC2016  # $1 is for the hook shell, not for us
  MMARGS+=(--skip=essential/unlink
           --setup-hook='mkdir -p "$1"/var/cache/apt/archives/'
           --setup-hook="sync-in '$CACHE' /var/cache/apt/archives/"
           --customize-hook="sync-out /var/cache/apt/archives '$CACHE'")
fi
t=$(date +%s)
mmdebstrap "${MMARGS[@]}" "$SUITE" "$CHROOT" "$MIRROR"
note "mmdebstrap: exit status 0, $(( $(date +%s) - t )) s, $(grep -c '^Package:' "$CHROOT/var/lib/dpkg/status") packages, $(du -sh --one-file-system "$CHROOT" | cut -f1)"

# ---------------------------------------------------------------- step 2: mounts + install
say "2. mounts, then apt-get update && apt-get install -y ./$DEBNAME"
mount -t proc proc "$CHROOT/proc"
mount --bind /dev/pts "$CHROOT/dev/pts"     # apt's terminal log wants a pty
if [[ $CACHE_ON -eq 1 ]]; then
  mkdir -p "$CACHE/partial"
  mount --bind "$CACHE" "$CHROOT/var/cache/apt/archives"
fi
mounts_under "$CHROOT" | sed 's/^/mounted: /'
cp "$DEB" "$CHROOT/root/$DEBNAME"
mkdir -p "$CHROOT/root/t"

t=$(date +%s)
APTOUT=$WORK/.apt-install.$$.txt
set +e
in_chroot "cd /root && apt-get update && apt-get install -y ./$DEBNAME" > "$APTOUT" 2>&1
rc=$?
set -e
# The install output is long: the log gets all of it, the summary lines are repeated below.
sed 's/^/  | /' "$APTOUT"
note ""
note "apt summary:"
grep -E 'upgraded, .* newly installed|^Need to get|^After this operation|^Fetched|^E:|^W:' "$APTOUT" | sed 's/^/  /' || true
note "apt-get update && install: exit status $rc, $(( $(date +%s) - t )) s"
rm -f "$APTOUT"
[[ $rc -eq 0 ]] || { echo "FATAL: installing $DEBNAME failed"; exit 1; }
check "package state" ok "dpkg-query -W -f='\${Package} \${Version} \${Status}\n' $PKG"

# ---------------------------------------------------------------- step 3: smoke tests
say "3. smoke tests (in /root/t)"
check "--version"             ok   "isoslab --version"
check "extract phantom"       ok   "isoslab extract 'phantom:sphere?n=32' --iso 900 -o s.glb"
check "output file"           ok   "ls -la s.glb && test -s s.glb"
check "metrics"               ok   "isoslab metrics s.glb | head -20"
check "metrics: closed mesh"  ok   "isoslab metrics s.glb | grep -q '\"closed\": true'"
check "shared libraries"      ok   "! ldd /usr/bin/isoslab /usr/lib/x86_64-linux-gnu/libisoslab.so.* /usr/lib/x86_64-linux-gnu/isoslab/*.so /usr/lib/python3/dist-packages/isoslab/*.so | grep 'not found'"
check "ldconfig cache"        ok   "ldconfig -p | grep libisoslab"
check "man page"              ok   "man -w isoslab || ls -la /usr/share/man/man1/isoslab.1.gz"

if ! in_chroot "dpkg-query -W -f='\${Status}' python3-numpy 2>/dev/null | grep -q 'ok installed'"; then
  note "python3-numpy did not come with the Recommends; installing it"
  check "install python3-numpy" ok "apt-get install -y python3-numpy | tail -3"
else
  note "python3 and python3-numpy came in through Recommends"
fi
check "python import"         ok   "python3 -c 'import isoslab; print(isoslab.__version__)'"
check "python marching_cubes + extract" ok "python3 - <<'EOF'
import numpy as np, isoslab
z, y, x = np.mgrid[:32, :32, :32]
vol = np.sqrt((x - 15.5)**2 + (y - 15.5)**2 + (z - 15.5)**2).astype(np.float32)
v, f, n, val = isoslab.marching_cubes(vol, 10.0)
m = isoslab.metrics(v, f)
print('marching_cubes:', v.shape, f.shape, 'closed =', m['closed'])
assert m['closed'] and len(f) > 0
r = isoslab.extract('phantom:sphere?n=32', 'py.stl', iso=900)
print('extract: triangles =', r.get('triangles'), 'closed =', r.get('closed'))
EOF"

if ! in_chroot "command -v pkg-config" >/dev/null; then
  note "pkg-config is not in the minimal chroot; installing it"
  check "install pkg-config" ok "apt-get install -y --no-install-recommends pkg-config | grep -E 'newly installed|Setting up'"
fi
check "pkg-config"            ok   "pkg-config --cflags --libs isoslab && pkg-config --modversion isoslab"
check "cmake package files"   ok   "ls /usr/lib/x86_64-linux-gnu/cmake/isoslab && test -f /usr/lib/x86_64-linux-gnu/cmake/isoslab/isoslabConfig.cmake"
check "headers"               ok   "ls /usr/include/isoslab && test -n \"\$(ls -A /usr/include/isoslab)\""
check "dpkg -L (first 50)"    ok   "dpkg -L $PKG | head -50; echo \"... \$(dpkg -L $PKG | wc -l) paths in total\""

# ---------------------------------------------------------------- step 4: removal
say "4. apt-get remove --purge -y $PKG"
check "remove --purge"        ok   "apt-get remove --purge -y $PKG 2>&1 | grep -vE '^  [a-z0-9]'"
check "library gone"          fail "ls /usr/lib/x86_64-linux-gnu/libisoslab*"
check "ldconfig cache clean"  fail "ldconfig -p | grep libisoslab"
check "package gone"          fail "dpkg-query -W $PKG"
check "no files left behind"  ok   "left=\$(ls -d /usr/bin/isoslab /usr/include/isoslab /usr/lib/x86_64-linux-gnu/isoslab /usr/lib/x86_64-linux-gnu/cmake/isoslab /usr/lib/python3/dist-packages/isoslab /usr/share/doc/isoslab /usr/share/man/man1/isoslab.1.gz 2>/dev/null); [ -z \"\$left\" ] || { echo \"left behind:\"; find \$left; false; }"

# ---------------------------------------------------------------- summary
say "summary"
printf '%s\n' "${RESULTS[@]}"
note "$(( ${#RESULTS[@]} - FAILS )) passed, $FAILS failed"
[[ $FAILS -eq 0 ]]
