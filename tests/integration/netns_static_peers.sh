#!/usr/bin/env bash
# ROS_STATIC_PEERS over a link without multicast, as a radio link: the vehicle and the ground
# station in two network namespaces joined by a veth pair whose multicast is off. The vehicle's
# mlmap_node runs with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (its own traffic stays on its host)
# and ROS_STATIC_PEERS naming the ground station; the ground station (mlmap_inspect, SUBNET) knows
# nothing of the vehicle. With the peer set, the ground station gets the node's status; without
# it, nothing ever crosses (the control case, so the test fails if the peers were ignored).
#   netns_static_peers.sh <bin dir> <out dir> <domain id>
# Needs root (unshare, nsenter, ip), as the other namespace tests.
set -uo pipefail
bin=$1 out=$2
here=$(cd "$(dirname "$0")" && pwd)
export ROS_DOMAIN_ID=$3
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_STATIC_PEERS ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE \
  ROS_SECURITY_STRATEGY ROS_SECURITY_ENCLAVE_OVERRIDE
[ "$(id -u)" = 0 ] || { echo "FAIL: needs root for network namespaces"; exit 1; }
for tool in ip unshare nsenter; do
  command -v $tool >/dev/null || { echo "FAIL: $tool missing (iproute2, util-linux)"; exit 1; }
done
rm -rf "$out" && mkdir -p "$out"
tag=mlsp$$
# shellcheck source=../support/netns.sh
source "$here/../support/netns.sh"   # pids, killed on exit; netns_new; in_ns
netns_pid=""
netns_new; vehicle=$netns_pid
netns_new; ground=$netns_pid
set -e
ip link add "${tag}v" type veth peer name "${tag}g"
ip link set "${tag}v" netns "$vehicle"
ip link set "${tag}g" netns "$ground"
in_ns "$vehicle" ip addr add 10.78.0.1/24 dev "${tag}v"
in_ns "$ground" ip addr add 10.78.0.2/24 dev "${tag}g"
for side in "$vehicle:${tag}v" "$ground:${tag}g"; do
  ns=${side%%:*} dev=${side#*:}
  in_ns "$ns" ip link set lo up
  in_ns "$ns" ip link set "$dev" up multicast off   # a link without multicast
done
set +e

fail() { echo "FAIL: $*"; exit 1; }
# mlmap_node in the vehicle namespace with the given static peers (its pid in $node).
start_node() {
  ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_STATIC_PEERS=$1 \
    nsenter -t "$vehicle" -n "$bin/mlmap_node" --report-every 0 > "$out/node_$2.log" 2>&1 &
  node=$!; pids+=("$node")
}
# The ground station for at most $1 s, its log named $2; more options after.
ground_inspect() {
  ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET nsenter -t "$ground" -n "$bin/mlmap_inspect" \
    --duration "$1" --expect mlmap/status "${@:3}" > "$out/inspect_$2.log" 2>&1
}

start_node "" without
ground_inspect 6 without; without_rc=$?
kill -INT "$node"; wait "$node"

start_node "10.78.0.2" with
ground_inspect 30 with --until-expected; with_rc=$?   # discovery may take seconds when loaded
kill -INT "$node"; wait "$node"; node_rc=$?

for f in node_without inspect_without node_with inspect_with; do echo "== $f"; cat "$out/$f.log"; done
echo "without peers: inspect $without_rc; with peers: inspect $with_rc, node $node_rc"
[ $without_rc -ne 0 ] || fail "the status crossed without static peers: the test does not isolate them"
grep -q "mlmap/status *expected, nothing received" "$out/inspect_without.log" ||
  fail "without static peers the ground station failed for another reason than no discovery"
grep -q "the node was not discovered" "$out/inspect_without.log" ||
  fail "without static peers the ground station did not say that it found no node"
[ $with_rc -eq 0 ] || fail "ROS_STATIC_PEERS=10.78.0.2: the ground station got no status"
[ $node_rc -eq 0 ] || fail "mlmap_node did not stop cleanly"
echo "OK: the static peer carried discovery over a link without multicast"
