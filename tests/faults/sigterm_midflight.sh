#!/usr/bin/env bash
# SIGTERM in the middle of a flight, across processes on loopback:
#   sigterm_midflight.sh <bin dir> <out dir> <domain id>
# 1. The simulator streams clouds at 20 Hz into mlmap_node (map_file: load and save the same
#    file, missing at first). Once 20 frames are mapped, while clouds keep coming, the node gets SIGTERM:
#    it must exit 0 within 10 s, having saved every frame it mapped, and leave no temporary file.
# 2. A second node starts from that file while the flight goes on, maps more, gets SIGTERM: its
#    file must hold the frames of both runs (the restart loaded the map and went on from it).
set -uo pipefail
bin=$1 out=$2
export ROS_DOMAIN_ID=$3
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
readonly stop_bound_s=10
rm -rf "$out" && mkdir -p "$out"
publisher='' node=''
cleanup() { for p in $node $publisher; do kill "$p" 2>/dev/null; done; }
trap cleanup EXIT
fail() { for f in "$out"/*.log; do echo "== $f"; cat "$f"; done; echo "FAIL: $*"; exit 1; }

printf 'local_map: {size_cells: [45, 45, 25]}\nmap_file: {load_path: %s/map.mlmap, load_missing_ok: true, save_path: %s/map.mlmap}\n' \
  "$out" "$out" > "$out/node.yaml"

# Stops the node with SIGTERM; sets $mapped and $stop_s, fails unless it exits 0 in time.
stop_node() {
  local log=$1 start end
  start=$(date +%s.%N)
  kill -TERM "$node"
  wait "$node"; local rc=$?
  end=$(date +%s.%N)
  node=
  stop_s=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f", b - a }')
  [ "$rc" -eq 0 ] || fail "$log: exit status $rc after SIGTERM"
  awk -v s="$stop_s" -v b="$stop_bound_s" 'BEGIN { exit !(s <= b) }' || fail "$log: took $stop_s s to stop (bound $stop_bound_s s)"
  mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped.*/\1/p' "$out/$log")
  grep -q "shutdown: saved the map to '$out/map.mlmap'" "$out/$log" || fail "$log: no save at shutdown"
  compgen -G "$out/*.tmp-*" > /dev/null && fail "$log: a temporary file was left behind"
}
file_frames() {
  "$bin/mlmap_map_tool" "$out/map.mlmap" --info > "$out/info.log" 2>&1 || fail "mlmap_map_tool cannot read the map"
  sed -n 's/.*; \([0-9]*\) frames mapped.*/\1/p' "$out/info.log"
}
# Waits until the node's progress line says it mapped at least $2 frames (up to 120 s: under
# AddressSanitizer the simulator renders a frame in about a second).
wait_mapped() {
  for _ in $(seq 1 1200); do
    local n
    n=$(sed -n 's/.*frames: [0-9]* received, \([0-9]*\) mapped.*/\1/p' "$out/$1" | tail -1)
    [ "${n:-0}" -ge "$2" ] && return 0
    sleep 0.1
  done
  fail "$1: fewer than $2 frames mapped after 120 s"
}

# ---- 1. SIGTERM mid-flight ---------------------------------------------------------------------
"$bin/mlmap_node" --config "$out/node.yaml" --report-every 0.2 > "$out/node1.log" 2>&1 &
node=$!
"$bin/mlmap_sensor_publisher" --config "$out/node.yaml" --mode cloud --rate 20 --speed 2 \
  --max-frames 600 > "$out/publisher.log" 2>&1 &
publisher=$!
wait_mapped node1.log 20
stop_node node1.log
mapped1=$mapped
kill -0 "$publisher" 2>/dev/null || fail "the flight ended before the SIGTERM: not mid-flight"
frames=$(file_frames)
echo "node 1: SIGTERM after ${mapped1} frames mapped, stopped in ${stop_s} s, the file holds ${frames} frames"
[ "${mapped1:-0}" -ge 20 ] || fail "node 1 mapped ${mapped1:-no} frames"
[ "${frames:-0}" -eq "$mapped1" ] || fail "the saved map holds ${frames:-no} frames, the node mapped $mapped1"

# ---- 2. restart from the file, mid-flight again ----------------------------------------------------
"$bin/mlmap_node" --config "$out/node.yaml" --report-every 0.2 > "$out/node2.log" 2>&1 &
node=$!
wait_mapped node2.log 10
stop_node node2.log
mapped2=$mapped
grep -q "loaded map '$out/map.mlmap'.* $mapped1 frames mapped before" "$out/node2.log" || fail "node 2 did not load the map of node 1"
frames=$(file_frames)
echo "node 2: loaded ${mapped1} frames, mapped ${mapped2} more, stopped in ${stop_s} s, the file holds ${frames} frames"
[ "${frames:-0}" -eq $((mapped1 + mapped2)) ] || fail "the file holds ${frames:-no} frames, not $mapped1 + $mapped2"
echo "PASS: SIGTERM mid-flight twice: exit 0 within ${stop_bound_s} s, map saved, the restart went on from it"
