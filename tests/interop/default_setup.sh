#!/usr/bin/env bash
# One cell of the default-setup matrix: mlmap_node next to ROS 2 Jazzy peers that use their rmw's
# defaults, on a host with a network interface (a network namespace of this test's own: loopback
# and a veth pair 192.0.2.1/24 <-> 192.0.2.2/24, multicast routed through it, as on a LAN; nothing
# reaches the real interfaces). Three peer participants, as a ROS 2 user has them: a publisher of
# the sensor's clouds and poses, a subscriber of every map layer, and a second subscriber that
# joins mid-flight (a `ros2 topic echo` opened later, the ros2 daemon). Both sides set only
# ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE (or leave it unset) and, with OFF, ROS_STATIC_PEERS.
#
#   default_setup.sh <bin dir> <cyclone peer> <out dir> <domain id> <peer> <range> <order>
#     peer:  cyclone   rmw_cyclonedds_cpp: mlmap_cyclone_peer (Cyclone DDS 0.10) with the
#                      configuration Jazzy's rmw_cyclonedds_cpp gives Cyclone for the range
#            fastdds   rmw_fastrtps_cpp: mlmap_sensor_publisher and mlmap_inspect (every layer the
#                      node publishes) with shared memory + UDPv4, as Jazzy's rmw_fastrtps_cpp sets
#                      up Fast DDS for the range
#     range: unset | LOCALHOST | OFF (OFF with ROS_STATIC_PEERS naming the node's host)
#     order: node-first | peer-first
# Passes when the node stays alive and stops cleanly, and: with unset and LOCALHOST, every frame
# sent is mapped and both subscribers get every map layer; with OFF (no discovery at all, as ROS 2
# defines it, static peers ignored) nothing crosses either way.
# Needs root (unshare, nsenter, ip), as the other namespace tests.
set -uo pipefail
bin=$1 peer=$2 out=$3
export ROS_DOMAIN_ID=$4
peer_kind=$5 range=$6 order=$7
here=$(cd "$(dirname "$0")" && pwd)
case "$peer_kind:$range:$order" in
  cyclone:*:* | fastdds:*:*) ;;
  *) echo "usage: $0 <bin dir> <cyclone peer> <out dir> <domain> cyclone|fastdds unset|LOCALHOST|OFF node-first|peer-first"; exit 2 ;;
esac
case "$range" in unset | LOCALHOST | OFF) ;; *) echo "bad range $range"; exit 2 ;; esac
case "$order" in node-first | peer-first) ;; *) echo "bad order $order"; exit 2 ;; esac
[ "$(id -u)" = 0 ] || { echo "FAIL: needs root for a network namespace"; exit 1; }
unset FASTRTPS_DEFAULT_PROFILES_FILE CYCLONEDDS_URI ROS_STATIC_PEERS ROS_AUTOMATIC_DISCOVERY_RANGE \
  ROS_LOCALHOST_ONLY ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE
[ "$range" = unset ] || export ROS_AUTOMATIC_DISCOVERY_RANGE=$range
[ "$range" = OFF ] && export ROS_STATIC_PEERS=192.0.2.1
rm -rf "$out" && mkdir -p "$out"
fail() { echo "FAIL ($peer_kind, range $range, $order): $*"; exit 1; }

# shellcheck source=../support/netns.sh
source "$here/../support/netns.sh"   # pids, killed on exit; netns_new; in_ns
netns_pid=""
netns_new; ns=$netns_pid
set -e
in_ns "$ns" ip link set lo up
in_ns "$ns" ip link add mlds0 type veth peer name mlds1
in_ns "$ns" ip addr add 192.0.2.1/24 dev mlds0
in_ns "$ns" ip addr add 192.0.2.2/24 dev mlds1
in_ns "$ns" ip link set mlds0 up multicast on
in_ns "$ns" ip link set mlds1 up multicast on
in_ns "$ns" ip route add 224.0.0.0/4 dev mlds0
set +e

# 8 s of flight at 10 Hz: a subscriber that joins 2.5 s in and whose first announcements went
# unanswered (a loaded machine) still matches at Fast DDS's next periodic one, 3 s later, while
# every layer is still being published.
frames=80
layers_cloud=(mlmap/awareness/occupied mlmap/local_map/occupied mlmap/global_map/occupied mlmap/esdf/slice)
layers_grid=(mlmap/grid mlmap/map)
# As cyclone_to_mlmap.sh: a 9 m window so the flight retires submaps into the global map; queues
# long enough that a loaded machine delays frames rather than dropping them.
printf 'local_map: {size_cells: [45, 45, 25]}\npipeline: {input_queue_capacity: 64}\n' > "$out/node.yaml"
# rmw_fastrtps_cpp's participants have Fast DDS's shared memory transport beside UDPv4.
printf 'dds: {shared_memory: true}\n' > "$out/peer.yaml"
cat "$out/node.yaml" >> "$out/peer.yaml"

# What Jazzy's rmw_cyclonedds_cpp (check_create_domain) gives Cyclone DDS for each range.
case "$range" in
  unset)  # SUBNET: multicast stays on; participant indexes, so data and discovery ports differ
    discovery='<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>'
    general='' ;;
  LOCALHOST)
    discovery='<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="localhost"/></Peers>'
    general='<General><AllowMulticast>false</AllowMulticast></General>' ;;
  OFF)  # static peers ignored; a tag nobody else has
    discovery="<ParticipantIndex>none</ParticipantIndex><Tag>ros_discovery_off_$$</Tag>"
    general='<General><AllowMulticast>false</AllowMulticast></General>' ;;
esac
printf '<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="any">%s<Discovery>%s</Discovery></Domain></CycloneDDS>\n' \
  "$general" "$discovery" > "$out/cyclone.xml"
export CYCLONEDDS_URI="file://$out/cyclone.xml"

start_node() {
  nsenter -t "$ns" -n "$bin/mlmap_node" --config "$out/node.yaml" --report-every 0 > "$out/node.log" 2>&1 &
  node=$!; pids+=("$node")
}
# subscriber NAME SECONDS: a subscriber of every map layer that stays subscribed that long (as a
# ROS 2 node does: it must still be there when the next one joins), in the background (its pid in
# $sub); it fails unless every layer came.
subscriber() {
  if [ "$peer_kind" = cyclone ]; then
    local topics=() t
    for t in "${layers_cloud[@]}"; do topics+=(--cloud-topic "rt/$t"); done
    for t in "${layers_grid[@]}"; do topics+=(--grid-topic "rt/$t"); done
    nsenter -t "$ns" -n "$peer" listen --out "$out/$1" --ready-file "$out/$1.ready" "${topics[@]}" \
      --expect-clouds 1 --expect-grids 1 --stay "$2" --timeout "$2" > "$out/$1.log" 2>&1 &
  else
    nsenter -t "$ns" -n "$bin/mlmap_inspect" --config "$out/peer.yaml" --expect-all --duration "$2" \
      > "$out/$1.log" 2>&1 &
  fi
  sub=$!; pids+=("$sub")
}
# publisher WAIT: flies the built-in scenario, $frames frames at 10 Hz, in the background.
publisher() {
  if [ "$peer_kind" = cyclone ]; then
    nsenter -t "$ns" -n "$peer" fly --max-frames $frames --rate 10 --speed 2 \
      --wait-for-subscriber "$1" > "$out/publisher.log" 2>&1 &
  else
    nsenter -t "$ns" -n "$bin/mlmap_sensor_publisher" --config "$out/peer.yaml" --max-frames $frames \
      --rate 10 --speed 2 --wait-for-subscriber "$1" > "$out/publisher.log" 2>&1 &
  fi
  pub=$!; pids+=("$pub")
}

expect_exchange=1
[ "$range" = OFF ] && expect_exchange=0
# The first subscriber stays past the flight (8 s, after up to 3 s of discovery and settling) and
# the mapping of its frames; the second joins 2.5 s into the run and stays as long.
if [ $expect_exchange = 1 ]; then early_s=20 late_s=17 wait_s=30; else early_s=8 late_s=6 wait_s=6; fi
start=$(date +%s%N)
if [ "$order" = node-first ]; then
  start_node; sleep 1
  subscriber early $early_s; early=$sub
  publisher $wait_s
else
  subscriber early $early_s; early=$sub
  publisher $wait_s
  sleep 2; start_node
fi
sleep 2.5   # the flight is under way (or, with OFF, would be): the second subscriber joins
subscriber late $late_s; late=$sub
wait "$pub"; pub_rc=$?
wait "$early"; early_rc=$?
wait "$late"; late_rc=$?
node_alive=1
kill -0 "$node" 2>/dev/null || node_alive=0
kill -INT "$node" 2>/dev/null
wait "$node"; node_rc=$?
for f in node publisher early late; do echo "== $f"; tail -n 25 "$out/$f.log"; done
echo "publisher $pub_rc, subscribers $early_rc / $late_rc, node $node_rc (alive at the end: $node_alive)," \
  "$(( ($(date +%s%N) - start) / 1000000 )) ms"

grep -q "Assertion" "$out/node.log" && fail "mlmap_node aborted: $(grep -m1 Assertion "$out/node.log")"
[ $node_alive = 1 ] || fail "mlmap_node died during the run (exit $node_rc)"
[ $node_rc = 0 ] || fail "mlmap_node did not stop cleanly (exit $node_rc)"
mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped.*/\1/p' "$out/node.log")
if [ $expect_exchange = 1 ]; then
  [ $pub_rc = 0 ] || fail "the publisher failed (exit $pub_rc)"
  [ "${mapped:-0}" -eq $frames ] || fail "the node mapped ${mapped:-no} frames of $frames"
  [ $early_rc = 0 ] || fail "the first subscriber missed a map layer (exit $early_rc)"
  [ $late_rc = 0 ] || fail "the subscriber that joined mid-flight missed a map layer (exit $late_rc)"
  echo "PASS: node alive, $mapped of $frames frames mapped, every layer at both subscribers"
else
  [ "${mapped:-0}" -eq 0 ] || fail "with OFF the node mapped $mapped frames: discovery was not off"
  [ $early_rc != 0 ] && [ $late_rc != 0 ] || fail "with OFF a subscriber received the node's layers"
  echo "PASS: node alive and isolated (0 frames mapped, nothing received), as ROS 2 defines OFF"
fi
