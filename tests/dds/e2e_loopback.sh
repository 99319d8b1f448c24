#!/usr/bin/env bash
# End to end across processes on loopback: mlmap_sensor_publisher -> mlmap_node -> mlmap_inspect.
#   e2e_loopback.sh <bin dir> <out dir> <domain id> <mode: cloud|depth|replay> [<frames dir>]
# cloud / depth: the simulator flies the built-in scenario; passes when every frame is mapped,
#   every enabled layer reaches the inspector and the received occupied voxels agree with the
#   simulator's ground truth (precision >= 0.9).
# replay: the real RGB-D frames of <frames dir> are replayed as depth images; passes when every
#   frame is mapped, every layer arrives, and the map received over DDS has the size of the map
#   mlmap_demo makes offline from the same frames with the same engine settings (within 2 %).
set -uo pipefail
bin=$1 out=$2 mode=${4:-cloud} frames_dir=${5:-}
export ROS_DOMAIN_ID=$3
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
rm -rf "$out" && mkdir -p "$out"
here=$(cd "$(dirname "$0")" && pwd)
cfg="$out/node.yaml"
if [ "$mode" = replay ]; then
  cp "$here/../../config/mlmap_node_replay.yaml" "$cfg"
  frames=$(ls "$frames_dir"/frame-*.depth.png | wc -l)
  # 4 Hz: every frame must be mapped, and the node maps these 5 cm frames at about 6 Hz in the
  # test command's AddressSanitizer build (at 10 Hz it dropped a third of them).
  publish=(--frames-dir "$frames_dir" --mode depth --rate 4)
  inspect=()
else
  # A 9 m window so the 8 s flight retires submaps with walls in them into the global map;
  # queues long enough that a loaded machine delays frames rather than dropping them.
  printf 'local_map: {size_cells: [45, 45, 25]}\npipeline: {input_queue_capacity: 64}\n' > "$cfg"
  if [ "$mode" = depth ]; then
    cat "$here/../../config/mlmap_node_depth.yaml" >> "$cfg"  # the depth topics, as docker/compose.yaml
  fi
  frames=40
  publish=(--mode "$mode" --max-frames 40 --rate 20 --speed 4)
  inspect=(--default-scenario --min-precision 0.9)
fi

# Progress lines every second, as a user runs it: warnings must not repeat with them.
"$bin/mlmap_node" --config "$cfg" --report-every 1 > "$out/node.log" 2>&1 &
node=$!
"$bin/mlmap_inspect" --config "$cfg" --out "$out" --expect-all "${inspect[@]}" \
  --idle-stop 3 --duration 120 > "$out/inspect.log" 2>&1 &
inspector=$!
trap 'kill $node $inspector 2>/dev/null' EXIT

"$bin/mlmap_sensor_publisher" --config "$cfg" "${publish[@]}" > "$out/publisher.log" 2>&1
pub_rc=$?
kill -INT $node
wait $node
node_rc=$?
wait $inspector
inspect_rc=$?
for f in publisher node inspect; do echo "== $f"; cat "$out/$f.log"; done
echo "publisher $pub_rc, node $node_rc, inspector $inspect_rc"
[ $pub_rc -eq 0 ] && [ $node_rc -eq 0 ] && [ $inspect_rc -eq 0 ] || { echo "FAIL: a process failed"; exit 1; }
mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped.*/\1/p' "$out/node.log")
# The hits outside the local window are explained at most once while mapping, and totalled at
# most once at the end, however many progress lines there were.
progress=$(grep -c "frames: " "$out/node.log")
explained=$(grep -c "hits are falling outside the local window" "$out/node.log")
totalled=$(grep -c "outside the local window: [0-9]* points in range" "$out/node.log")
echo "progress lines $progress, window warnings $explained while mapping, $totalled at the end"
[ "$explained" -le 1 ] && [ "$totalled" -le 1 ] ||
  { echo "FAIL: the window warning repeats"; exit 1; }
[ "${mapped:-0}" -eq "$frames" ] || { echo "FAIL: the node mapped ${mapped:-no} frames of $frames"; exit 1; }
for f in dds_map_top.png dds_awareness_top.png dds_grid.png dds_esdf_slice.png summary.json; do
  [ -s "$out/$f" ] || { echo "FAIL: the inspector wrote no $f"; exit 1; }
done
last_points() {  # last_points of a topic in summary.json
  sed -n "s/.*\"mlmap\/$1\/occupied\": {.*\"last_points\": \([0-9]*\)}.*/\1/p" "$out/summary.json"
}
# The latched global map as received must be the node's whole global map.
global=$(last_points global_map)
node_global=$(sed -n 's/.*"node_global_voxels": \([0-9]*\).*/\1/p' "$out/summary.json")
echo "global map: received ${global:-none} voxels, the node holds ${node_global:-?}"
if [ "$mode" = replay ]; then
  # Nothing leaves the 5 m window on a tabletop: the map is the local map.
  [ "${global:-0}" = "${node_global:--1}" ] || { echo "FAIL: global map"; exit 1; }
  "$bin/mlmap_demo" --frames "$frames_dir" --out "$out/offline" > "$out/offline.log" 2>&1 ||
    { cat "$out/offline.log"; echo "FAIL: mlmap_demo"; exit 1; }
  offline=$(sed -n 's/^  "occupied_voxels": \([0-9]*\),$/\1/p' "$out/offline/report.json")
  received=$(( $(last_points local_map) + global ))
  echo "occupied voxels: $received received over DDS, $offline mapped offline"
  # Same frames, same poses (through PoseStamped), same settings: the same map, voxel for voxel
  # in number (the node's threads change nothing when no frame is dropped).
  [ "${offline:-0}" -gt 1000 ] && [ "$received" -eq "$offline" ] || { echo "FAIL: maps differ"; exit 1; }
else
  [ "${global:-0}" -gt 0 ] && [ "$global" = "$node_global" ] || { echo "FAIL: global map"; exit 1; }
fi
