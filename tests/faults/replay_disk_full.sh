#!/usr/bin/env bash
# mlmap_replay writing its pictures to a full disk (issue 26 item 6):
#   replay_disk_full.sh <bin dir> <out dir>
# The pictures' folder (--out) lives on a 1 MB tmpfs, filled, in a private mount namespace
# (unshare -m), so the test needs root (CI runs as root); elsewhere it is skipped (exit 77).
# The map (--save-map) and the voxel list (--voxels-out) go to an ordinary folder. They are
# written first, so they must be complete and loadable; the first picture fails with the path
# and the reason, exit status 1, and neither a partial picture nor a temporary file is left.
set -uo pipefail
bin=$1 out=$2
if [ -z "${MLMAP_IN_MOUNT_NS:-}" ]; then
  if [ "$(id -u)" -ne 0 ] || ! unshare -m --propagation private true 2>/dev/null; then
    echo "SKIP: needs root and mount namespaces (unshare -m) for a tmpfs that can be filled"
    exit 77
  fi
  exec unshare -m --propagation private env MLMAP_IN_MOUNT_NS=1 bash "$0" "$@"
fi
rm -rf "$out" && mkdir -p "$out/disk" "$out/keep"
mount -t tmpfs -o size=1m tmpfs "$out/disk" || { echo "SKIP: cannot mount a tmpfs here"; exit 77; }
fail() { cat "$out/replay.log"; echo "FAIL: $*"; exit 1; }
mkdir -p "$out/disk/pictures"
dd if=/dev/zero of="$out/disk/filler" bs=4k 2> /dev/null
[ "$(df --output=avail -B1 "$out/disk" | tail -1)" -lt 8192 ] || fail "could not fill the tmpfs"

"$bin/mlmap_replay" --max-frames 5 --out "$out/disk/pictures" --save-map "$out/keep/map.mlmap" \
  --voxels-out "$out/keep/voxels.txt" > "$out/replay.log" 2>&1
rc=$?
[ "$rc" -eq 1 ] || fail "exit status $rc, expected 1 (a picture could not be written)"
grep -q "cannot write '$out/disk/pictures/map_top.png'.*No space left on device" "$out/replay.log" ||
  fail "no clear message naming the picture and the reason"
"$bin/mlmap_map_tool" "$out/keep/map.mlmap" --info > "$out/info.log" 2>&1 || fail "the saved map does not load"
listed=$(sed -n 's/^# .*resolution_m [0-9.e+-]*, \([0-9]*\) voxels$/\1/p' "$out/keep/voxels.txt")
lines=$(grep -vc '^#' "$out/keep/voxels.txt")
[ -n "$listed" ] && [ "$listed" -gt 100 ] && [ "$listed" -eq "$lines" ] ||
  fail "the voxel list is not whole: header says '${listed:-nothing}', $lines lines"
[ -z "$(ls -A "$out/disk/pictures")" ] || fail "left in the full folder: $(ls -A "$out/disk/pictures")"
compgen -G "$out/disk/*.tmp-*" > /dev/null && fail "a temporary file was left behind"
echo "PASS: map and voxel list written first and whole ($listed voxels); the picture on the full" \
  "disk failed with its path, exit 1, nothing partial left"
