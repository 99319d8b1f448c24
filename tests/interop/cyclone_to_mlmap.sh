#!/usr/bin/env bash
# Cyclone DDS -> mlmap, on loopback: mlmap_cyclone_peer flies the built-in scenario and publishes
# its clouds (640 x 480 organised, 4.9 MB each) and poses through Cyclone DDS, BEST_EFFORT, on the
# node's default topics; mlmap_node (Fast DDS) maps them and mlmap_inspect watches its outputs.
# Passes when the node mapped every frame and the occupied voxels the inspector received agree
# with the simulator's ground truth (precision >= 0.9), as in tests/dds/e2e_loopback.sh.
#   cyclone_to_mlmap.sh <bin dir of mlmap_node> <cyclone peer> <cyclone config xml> <out dir> <domain id>
set -uo pipefail
bin=$1 peer=$2 cyclone_xml=$3 out=$4
export ROS_DOMAIN_ID=$5
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # Fast DDS: never leave loopback
export CYCLONEDDS_URI=file://$cyclone_xml       # Cyclone: the same, with unicast discovery
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
frames=40
rm -rf "$out" && mkdir -p "$out"
cfg="$out/node.yaml"
# As e2e_loopback.sh: a 9 m window so the flight retires submaps into the global map; queues long
# enough that a loaded machine delays frames rather than dropping them.
printf 'local_map: {size_cells: [45, 45, 25]}\npipeline: {input_queue_capacity: 64}\n' > "$cfg"
start=$(date +%s%N)

"$bin/mlmap_node" --config "$cfg" --report-every 0 > "$out/node.log" 2>&1 &
node=$!
"$bin/mlmap_inspect" --config "$cfg" --out "$out" --default-scenario --expect-all --min-precision 0.9 \
  --idle-stop 3 --duration 60 > "$out/inspect.log" 2>&1 &
inspect=$!
trap 'kill $node $inspect 2>/dev/null' EXIT

"$peer" fly --max-frames $frames --rate 20 --speed 4 > "$out/peer.log" 2>&1
peer_rc=$?
kill -INT $node
wait $node
node_rc=$?
wait $inspect
inspect_rc=$?
for f in peer node inspect; do echo "== $f"; cat "$out/$f.log"; done
echo "cyclone peer $peer_rc, node $node_rc, inspector $inspect_rc, $(( ($(date +%s%N) - start) / 1000000 )) ms"
mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped.*/\1/p' "$out/node.log")
[ "${mapped:-0}" -eq $frames ] || { echo "FAIL: the node mapped ${mapped:-no} frames of $frames"; exit 1; }
[ -s "$out/summary.json" ] || { echo "FAIL: the inspector wrote no summary"; exit 1; }
[ $peer_rc -eq 0 ] && [ $node_rc -eq 0 ] && [ $inspect_rc -eq 0 ]
