#!/usr/bin/env bash
# End to end across processes on loopback: mlmap_sensor_publisher -> mlmap_node -> mlmap_inspect.
# Passes when every enabled layer reaches the inspector and the occupied voxels it received agree
# with the simulator's ground truth (precision >= 0.9).
#   e2e_loopback.sh <bin dir> <out dir> <domain id> <mode: cloud|depth>
set -uo pipefail
bin=$1 out=$2 mode=${4:-cloud}
export ROS_DOMAIN_ID=$3
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE
rm -rf "$out" && mkdir -p "$out"
cfg="$out/node.yaml"
# A 9 m window so the 8 s flight retires submaps with walls in them into the global map; queues
# long enough that a loaded machine delays frames rather than dropping them.
printf 'local_map: {size_cells: [45, 45, 25]}\npipeline: {input_queue_capacity: 64}\n' > "$cfg"
if [ "$mode" = depth ]; then
  printf 'dds:\n  topics:\n    cloud: ""\n    depth_image: camera/depth/image_rect_raw\n    camera_info: camera/depth/camera_info\n' >> "$cfg"
fi

"$bin/mlmap_node" --config "$cfg" --report-every 0 > "$out/node.log" 2>&1 &
node=$!
"$bin/mlmap_inspect" --config "$cfg" --out "$out" --default-scenario --expect-all --min-precision 0.9 \
  --idle-stop 3 --duration 120 > "$out/inspect.log" 2>&1 &
inspect=$!
trap 'kill $node $inspect 2>/dev/null' EXIT

"$bin/mlmap_sensor_publisher" --config "$cfg" --mode "$mode" --max-frames 40 --rate 20 --speed 4 \
  > "$out/publisher.log" 2>&1
pub_rc=$?
kill -INT $node
wait $node
node_rc=$?
wait $inspect
inspect_rc=$?
for f in publisher node inspect; do echo "== $f"; cat "$out/$f.log"; done
echo "publisher $pub_rc, node $node_rc, inspector $inspect_rc"
mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped.*/\1/p' "$out/node.log")
[ "${mapped:-0}" -eq 40 ] || { echo "FAIL: the node mapped ${mapped:-no} frames of 40"; exit 1; }
for f in dds_map_top.png dds_awareness_top.png dds_grid.png dds_esdf_slice.png summary.json; do
  [ -s "$out/$f" ] || { echo "FAIL: the inspector wrote no $f"; exit 1; }
done
# The latched global map as received must be the node's whole global map, and not empty.
global=$(sed -n 's/.*"mlmap\/global_map\/occupied": {.*"last_points": \([0-9]*\)}.*/\1/p' "$out/summary.json")
node_global=$(sed -n 's/.*"node_global_voxels": \([0-9]*\).*/\1/p' "$out/summary.json")
echo "global map: received ${global:-none} voxels, the node holds ${node_global:-?}"
[ "${global:-0}" -gt 0 ] && [ "$global" = "$node_global" ] || { echo "FAIL: global map"; exit 1; }
[ $pub_rc -eq 0 ] && [ $node_rc -eq 0 ] && [ $inspect_rc -eq 0 ]
