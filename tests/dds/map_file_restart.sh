#!/usr/bin/env bash
# mlmap_node saves its map on SIGTERM and starts from it again, across processes on loopback.
#   map_file_restart.sh <bin dir> <out dir> <domain id>
# 1. The simulator flies 40 frames -> mlmap_node (map_file.save_path, saving every 0.5 s too);
#    SIGTERM: the node must map every frame, save the map and exit 0; mlmap_map_tool must read
#    the file back.
# 2. A new mlmap_node loads it (map_file.load_path) and receives no frame: a late inspector must
#    get the latched global map with exactly the file's global voxels, and the 2D grid.
# 3. SIGTERM again: with no new frame, the map it saves must be byte for byte the first one.
# 4. A truncated map and a map of another resolution stop the node at start with a clear
#    message, and the file is not overwritten.
set -uo pipefail
bin=$1 out=$2
here=$(cd "$(dirname "$0")" && pwd)
export ROS_DOMAIN_ID=$3
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
rm -rf "$out" && mkdir -p "$out"
fail() { for f in "$out"/*.log; do echo "== $f"; cat "$f"; done; echo "FAIL: $*"; exit 1; }

# A 9 m window, so that the 8 s flight retires submaps into the global map (as e2e_loopback.sh).
engine='local_map: {size_cells: [45, 45, 25]}\npipeline: {input_queue_capacity: 64}\n'
printf "${engine}map_file: {save_path: %s/first.mlmap, save_period_s: 0.5}\n" "$out" > "$out/save.yaml"
printf "${engine}map_file: {load_path: %s/first.mlmap, save_path: %s/second.mlmap}\n" "$out" "$out" \
  > "$out/load.yaml"

# The subject is the file, not the image: a 160 x 120 camera, and prerendered frames, so that a
# loaded machine delays the flight instead of sending bursts the node's input would drop.
bash "$here/../support/small_camera_scenario.sh" "$out/scenario.yaml" || fail "no small-camera scenario"

# ---- 1. map, SIGTERM, saved -------------------------------------------------------------------
"$bin/mlmap_node" --config "$out/save.yaml" --report-every 0 > "$out/node1.log" 2>&1 &
node=$!
trap 'kill $node 2>/dev/null' EXIT
"$bin/mlmap_sensor_publisher" --config "$out/save.yaml" --mode cloud --max-frames 40 --rate 20 \
  --speed 4 --prerender --scenario "$out/scenario.yaml" > "$out/publisher.log" 2>&1 || fail "publisher"
sleep 1
kill -TERM $node
wait $node || fail "node 1 exited with an error"
mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped.*/\1/p' "$out/node1.log")
[ "${mapped:-0}" -eq 40 ] || fail "node 1 mapped ${mapped:-no} frames of 40"
grep -q "shutdown: saved the map to '$out/first.mlmap'" "$out/node1.log" || fail "no save at shutdown"
grep -q "periodic save: saved the map to '$out/first.mlmap'" "$out/node1.log" || fail "no periodic save"
[ -s "$out/first.mlmap" ] || fail "no map file"
compgen -G "$out/*.tmp-*" > /dev/null && fail "a temporary file was left behind"
"$bin/mlmap_map_tool" "$out/first.mlmap" --info > "$out/info.log" 2>&1 || fail "mlmap_map_tool"
cat "$out/info.log"
file_global=$(sed -n 's/.*global map: \([0-9]*\) occupied voxels.*/\1/p' "$out/info.log")
file_frames=$(sed -n 's/.*; \([0-9]*\) frames mapped.*/\1/p' "$out/info.log")
[ "${file_frames:-0}" -eq 40 ] || fail "the file holds ${file_frames:-no} frames, not 40"
[ "${file_global:-0}" -gt 0 ] || fail "the file's global map is empty"

# ---- 2. restart from the file: the latched global map is the file's --------------------------
"$bin/mlmap_node" --config "$out/load.yaml" --report-every 0 > "$out/node2.log" 2>&1 &
node=$!
sleep 1
"$bin/mlmap_inspect" --config "$out/load.yaml" --out "$out/inspect" \
  --expect mlmap/global_map/occupied,mlmap/grid --duration 8 > "$out/inspect.log" 2>&1 ||
  fail "the inspector did not get the global map and the grid"
grep -q "loaded map '$out/first.mlmap'" "$out/node2.log" || fail "node 2 did not say it loaded the map"
received=$(sed -n 's/.*"mlmap\/global_map\/occupied": {.*"last_points": \([0-9]*\)}.*/\1/p' \
  "$out/inspect/summary.json")
echo "global map: ${received:-none} voxels received after the restart, $file_global in the file"
[ "${received:-0}" -eq "$file_global" ] || fail "the restarted node's global map differs from the file's"

# ---- 3. SIGTERM with no new frame: the same map again -----------------------------------------
kill -TERM $node
wait $node || fail "node 2 exited with an error"
cmp "$out/first.mlmap" "$out/second.mlmap" || fail "load + save changed the map"
# ---- 4. maps that do not fit are refused at start, and the file is left alone -----------------
head -c 5000 "$out/first.mlmap" > "$out/cut.mlmap"
printf "${engine}map_file: {load_path: %s/cut.mlmap, save_path: %s/cut.mlmap}\n" "$out" "$out" > "$out/cut.yaml"
"$bin/mlmap_node" --config "$out/cut.yaml" --duration 5 > "$out/node_cut.log" 2>&1 && fail "node started from a truncated map"
grep -q "cut.mlmap: truncated: 5000 bytes" "$out/node_cut.log" || fail "no clear message for a truncated map"
[ "$(stat -c %s "$out/cut.mlmap")" -eq 5000 ] || fail "the refused map file was overwritten"
printf 'local_map: {resolution_m: 0.1, size_cells: [45, 45, 25]}\nmap_file: {load_path: %s/first.mlmap, save_path: %s/first.mlmap}\n' \
  "$out" "$out" > "$out/other.yaml"
"$bin/mlmap_node" --config "$out/other.yaml" --duration 5 > "$out/node_other.log" 2>&1 && fail "node started from a map of another resolution"
grep -q "local_map.resolution_m is 0.2 in the map, 0.1 in the configuration" "$out/node_other.log" ||
  fail "no clear message for a map of another configuration"
cmp "$out/first.mlmap" "$out/second.mlmap" || fail "a refused start overwrote the map"

echo "PASS: saved $(stat -c %s "$out/first.mlmap") bytes at SIGTERM, reloaded, received $received global voxels, saved again identically"
