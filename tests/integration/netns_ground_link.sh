#!/usr/bin/env bash
# The vehicle and the ground station on two hosts of a LAN, made here with two network namespaces
# joined by a veth pair: multicast discovery between them as on a vehicle's network, and the link
# from the vehicle limited to 10 Mbit/s (tc tbf: this kernel has no netem).
#   netns_ground_link.sh <bin dir> <out dir> <domain id>
# Onboard namespace: mlmap_sensor_publisher (10 Hz, a 160 x 120 camera: the clouds stay onboard;
# shared memory to the node) -> mlmap_node.
# Ground namespace (UDP only: nothing can bypass the link through shared memory), mlmap_inspect as
# the bridge's stand-in:
#   late     joins 4 s into the flight, leaves cleanly 7 s later: every layer must have crossed;
#   vanish   joins at 4 s and is killed (-9) at 8 s, as a ground station that loses power;
#   rejoin   joins at 12 s and stays to the end: every layer again, and the age of what it sees;
#   latched  joins after the flight, when nothing new is published: must get the 2D grid and the
#            global map (TRANSIENT_LOCAL), the latter equal to the node's (its status says).
# Onboard, every frame must be mapped: the ground station's coming and going and the slow link do
# not slow or stop the mapping. Needs root (unshare, nsenter, ip, tc).
set -uo pipefail
bin=$1 out=$2
export ROS_DOMAIN_ID=$3
export ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET   # multicast discovery, inside the namespaces only
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
here=$(cd "$(dirname "$0")" && pwd)
frames=250 rate_hz=10
[ "$(id -u)" = 0 ] || { echo "FAIL: needs root for network namespaces"; exit 1; }
for tool in ip tc unshare nsenter; do
  command -v $tool >/dev/null || { echo "FAIL: $tool missing (iproute2, util-linux)"; exit 1; }
done
rm -rf "$out" && mkdir -p "$out"

tag=mlmap$$
# shellcheck source=../support/netns.sh
source "$here/../support/netns.sh"   # pids, killed on exit; netns_new; in_ns
netns_pid=""
netns_new; on=$netns_pid
netns_new; ground=$netns_pid
set -e
ip link add "${tag}a" type veth peer name "${tag}b"
ip link set "${tag}a" netns "$on"
ip link set "${tag}b" netns "$ground"
in_ns "$on" ip addr add 10.77.0.1/24 dev "${tag}a"
in_ns "$ground" ip addr add 10.77.0.2/24 dev "${tag}b"
for side in "$on:${tag}a" "$ground:${tag}b"; do
  ns=${side%%:*} dev=${side#*:}
  in_ns "$ns" ip link set lo up
  in_ns "$ns" ip link set "$dev" up multicast on
  in_ns "$ns" ip route add 224.0.0.0/4 dev "$dev"   # discovery multicast goes over the LAN
done
# 10 Mbit/s from the vehicle to the ground, at most 400 ms of queue (then the link drops).
in_ns "$on" tc qdisc add dev "${tag}a" root tbf rate 10mbit burst 32kbit latency 400ms
set +e

cfg="$out/node.yaml" ground_cfg="$out/ground.yaml"
# A 9 m window so the flight retires submaps into the global map; long queues so a busy machine
# delays frames rather than dropping them.
printf 'local_map: {size_cells: [45, 45, 25]}\npipeline: {input_queue_capacity: 64}\n' > "$cfg"
cp "$cfg" "$ground_cfg"
bash "$here/../support/small_camera_scenario.sh" "$out/scenario.yaml" || exit 1   # clouds stay onboard
printf 'dds:\n  profiles_file: %s\n  participant_profile: mlmap_udp_only\n' \
  "$here/../../config/dds/udp_only.xml" >> "$ground_cfg"
ground_inspect=(nsenter -t "$ground" -n "$bin/mlmap_inspect" --config "$ground_cfg" --as-bridge)
nsenter -t "$on" -n "$bin/mlmap_node" --config "$cfg" --report-every 0 > "$out/node.log" 2>&1 &
node=$!; pids+=("$node")
# Prerendered: a simulator falling behind on a loaded machine would send frames in bursts, which
# the node's input rightly drops (counted) and this test would take for a disturbed mapping.
nsenter -t "$on" -n "$bin/mlmap_sensor_publisher" --config "$cfg" --rate $rate_hz --prerender \
  --scenario "$out/scenario.yaml" --max-frames $frames > "$out/publisher.log" 2>&1 &
publisher=$!; pids+=("$publisher")
for _ in $(seq 1200); do   # the timeline below starts when the streaming does
  grep -q 'publishing clouds' "$out/publisher.log" && break
  kill -0 $publisher 2>/dev/null || break
  sleep 0.1
done
grep -q 'publishing clouds' "$out/publisher.log" || { cat "$out/publisher.log"; echo "FAIL: the publisher did not start"; exit 1; }
sleep 4
"${ground_inspect[@]}" --out "$out/late" --duration 7 --expect-all > "$out/late.log" 2>&1 &
late=$!; pids+=("$late")
"${ground_inspect[@]}" > "$out/vanish.log" 2>&1 &
vanish=$!; pids+=("$vanish")
sleep 4
kill -9 $vanish
sleep 4
"${ground_inspect[@]}" --out "$out/rejoin" --expect-all > "$out/rejoin.log" 2>&1 &
rejoin=$!; pids+=("$rejoin")
wait $publisher; pub_rc=$?
wait $late; late_rc=$?
sleep 3   # the last frames' layers cross
kill -INT $rejoin; wait $rejoin; rejoin_rc=$?
sleep 2   # the node is idle now: only what is latched can reach a newcomer
# Discovery on a loaded machine can take seconds: up to 30 s, ending as soon as the layers came.
latched_start=$SECONDS
"${ground_inspect[@]}" --out "$out/latched" --duration 30 --until-expected \
  --expect mlmap/grid,mlmap/global_map/occupied,mlmap/status > "$out/latched.log" 2>&1
latched_rc=$? latched_s=$((SECONDS - latched_start))
kill -INT $node; wait $node; node_rc=$?

for f in publisher node late rejoin latched; do echo "== $f"; cat "$out/$f.log"; done
echo "publisher $pub_rc, node $node_rc, late $late_rc, rejoin $rejoin_rc, latched $latched_rc"
fail() { echo "FAIL: $*"; exit 1; }
[ $pub_rc -eq 0 ] && [ $node_rc -eq 0 ] || fail "an onboard process failed"
[ $late_rc -eq 0 ] || fail "a late-joining ground station did not get every layer"
[ $rejoin_rc -eq 0 ] || fail "a ground station rejoining did not get every layer"
[ $latched_rc -eq 0 ] || fail "a ground station joining after the flight did not get the grid and global map"
[ $latched_s -lt 30 ] || fail "--until-expected: the latched station did not stop once its layers came (${latched_s} s)"
done_line=$(grep 'done: ' "$out/node.log")
mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped (\([0-9]*\) dropped.*/\1 \2/p' <<<"$done_line")
[ "$mapped" = "$frames 0" ] || fail "onboard mapping was disturbed: $done_line"
global=$(sed -n 's/.*"mlmap\/global_map\/occupied": {.*"last_points": \([0-9]*\)}.*/\1/p' "$out/latched/summary.json")
node_global=$(sed -n 's/.*"node_global_voxels": \([0-9]*\).*/\1/p' "$out/latched/summary.json")
echo "latched global map: ${global:-none} voxels received after the flight, the node reported ${node_global:-?}"
[ "${global:-0}" -gt 0 ] && [ "$global" = "$node_global" ] || fail "latched global map"
echo "age of the layers at the ground station (10 Mbit/s link), median / p99 [ms]:"
sed -n 's/.*"\([a-z_/]*\)": {"messages": \([0-9]*\),.*"age_ms": {"median": \([-0-9.e]*\), "p99": \([-0-9.e]*\)}.*/  \1: \3 \/ \4 (\2 messages)/p' \
  "$out/rejoin/summary.json"
