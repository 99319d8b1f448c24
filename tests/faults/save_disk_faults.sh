#!/usr/bin/env bash
# mlmap_node saving to a full disk and to a read-only one, across processes on loopback:
#   save_disk_faults.sh <bin dir> <out dir> <domain id>
# The map lives on a 1 MB tmpfs mounted in a private mount namespace (unshare -m), so the test
# needs root (CI runs as root); elsewhere it is skipped (exit 77) with a message.
# 1. A flight of 20 frames; SIGTERM: the map is saved (exit 0). That file is the good one.
# 2. Disk full (a filler file takes the rest of the tmpfs): a node loads the map, maps 20 more
#    frames, saves every 0.5 s and at SIGTERM. Every save must fail with the path and the reason,
#    be counted, leave the good file byte for byte and no temporary file; mapping goes on; the
#    node exits 1 because the final save failed.
# 3. The same with the folder's file system remounted read-only.
# 4. Writable again: the node saves (exit 0), and the file is a valid map.
set -uo pipefail
bin=$1 out=$2 domain=$3
if [ -z "${MLMAP_IN_MOUNT_NS:-}" ]; then
  if [ "$(id -u)" -ne 0 ] || ! unshare -m --propagation private true 2>/dev/null; then
    echo "SKIP: needs root and mount namespaces (unshare -m) for a tmpfs that can be filled and made read-only"
    exit 77
  fi
  exec unshare -m --propagation private env MLMAP_IN_MOUNT_NS=1 bash "$0" "$@"
fi
export ROS_DOMAIN_ID=$domain
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
rm -rf "$out" && mkdir -p "$out/disk"
mount -t tmpfs -o size=1m tmpfs "$out/disk" || { echo "SKIP: cannot mount a tmpfs here"; exit 77; }
map=$out/disk/map.mlmap
node=
trap '[ -n "$node" ] && kill $node 2>/dev/null' EXIT
fail() { for f in "$out"/*.log; do echo "== $f"; cat "$f"; done; echo "FAIL: $*"; exit 1; }

engine='local_map: {size_cells: [45, 45, 25]}\n'
printf "${engine}map_file: {save_path: %s}\n" "$map" > "$out/first.yaml"
printf "${engine}map_file: {load_path: %s, save_path: %s, save_period_s: 0.5}\n" "$map" "$map" > "$out/again.yaml"

# Runs a node with config $1 and log $2 through a 20-frame flight (or none when $3 is 0), then
# SIGTERM; sets $rc.
fly() {
  "$bin/mlmap_node" --config "$out/$1" --report-every 0 > "$out/$2" 2>&1 &
  node=$!
  if [ "$3" -gt 0 ]; then
    "$bin/mlmap_sensor_publisher" --config "$out/$1" --mode cloud --max-frames "$3" --rate 20 --speed 4 \
      > "$out/publisher_$2" 2>&1 || fail "publisher ($2)"
  fi
  sleep 1.5   # a few periodic saves
  kill -TERM "$node"
  wait "$node"; rc=$?
  node=
}
# Checks a run whose saves all failed with $1 in the reason.
check_failed_run() {
  local log=$1 reason=$2
  [ "$rc" -eq 1 ] || fail "$log: exit status $rc, expected 1 (the final save failed)"
  grep -q "periodic save: map not saved .*cannot .*'$map'.*$reason" "$out/$log" || fail "$log: no clear periodic save error ($reason)"
  grep -q "shutdown: map not saved .*cannot .*'$map'.*$reason" "$out/$log" || fail "$log: no clear shutdown save error ($reason)"
  grep -q "the map was not saved to '$map' at shutdown" "$out/$log" || fail "$log: no final error line"
  local mapped saves failed
  read -r mapped saves failed < <(sed -n 's/.*done: \([0-9]*\) frames mapped.*; \([0-9]*\) map saves, \([0-9]*\) failed.*/\1 \2 \3/p' "$out/$log")
  [ "${mapped:-0}" -eq 20 ] || fail "$log: mapped ${mapped:-no} frames of 20: mapping must go on"
  [ "${saves:-1}" -eq 0 ] && [ "${failed:-0}" -ge 2 ] || fail "$log: ${saves:-?} saves, ${failed:-?} failed"
  cmp "$map" "$out/good.mlmap" || fail "$log: the previous map file changed"
  compgen -G "$out/disk/*.tmp-*" > /dev/null && fail "$log: a temporary file was left behind"
  echo "$log: $failed saves failed ($reason), mapping went on ($mapped frames), exit 1, previous file intact"
}

# ---- 1. a good map -------------------------------------------------------------------------------
fly first.yaml node_first.log 20
[ "$rc" -eq 0 ] || fail "node_first.log: exit status $rc"
cp "$map" "$out/good.mlmap"
echo "first run: saved $(stat -c %s "$map") bytes"

# ---- 2. disk full --------------------------------------------------------------------------------
dd if=/dev/zero of="$out/disk/filler" bs=4k 2> /dev/null
[ "$(df --output=avail -B1 "$out/disk" | tail -1)" -lt 8192 ] || fail "could not fill the tmpfs"
fly again.yaml node_full.log 20
check_failed_run node_full.log "No space left on device"

# ---- 3. read-only --------------------------------------------------------------------------------
rm -f "$out/disk/filler"
mount -o remount,ro "$out/disk" || fail "cannot remount the tmpfs read-only"
fly again.yaml node_readonly.log 20
check_failed_run node_readonly.log "Read-only file system"

# ---- 4. writable again -----------------------------------------------------------------------------
mount -o remount,rw "$out/disk" || fail "cannot remount the tmpfs read-write"
fly again.yaml node_writable.log 0
[ "$rc" -eq 0 ] || fail "node_writable.log: exit status $rc with a writable folder"
grep -q "shutdown: saved the map to '$map'" "$out/node_writable.log" || fail "no save once writable"
"$bin/mlmap_map_tool" "$map" --info > "$out/info.log" 2>&1 || fail "the map saved afterwards does not load"
echo "PASS: full and read-only disks: clear errors, counted, exit 1, previous map intact, no temporary file"
