#!/usr/bin/env bash
# The simulated fleet on a LAN of network namespaces (tests/support/netns.sh): per vehicle a
# namespace with mlmap_sensor_publisher (config/worlds/fleet/uavK.yaml, prerendered) ->
# mlmap_node (namespace uavK, sharing its submaps on rt/uavK/mlmap/submaps), and mlmap_fleet in the
# hub namespace. Faults: every vehicle's link limited (tc tbf; this kernel has no netem, so no
# loss or delay here: tests/dds/emulated_link.h applies them in a process), and vehicle 1's link
# cut for --cut seconds mid-flight, then restored.
# Checks: every frame of every vehicle mapped, none dropped (the link does not slow onboard
# mapping); during the cut the merger marks uav1 STALE and keeps its voxels, and a few seconds
# after the link is back it is no longer stale (vehicles that finished flying turn stale again:
# a mapped, unchanging map sends nothing); after the flight
# the merger that lived through the cut holds the same map (per vehicle and merged) as a merger
# that joins at the end and gets every submap's last state from the writers' histories, and
# saves it as it stops (--save-map) with every voxel it held.
# Vehicle k flies config/worlds/fleet/uav((k-1) % 3 + 1).yaml (more than three share routes).
# Prints the merger's CPU time and peak memory.
#   fleet_netns.sh --bin DIR --out DIR --domain ID [--vehicles N] [--frames F] [--rate HZ]
#                  [--cut S] [--limit MBIT (0: none)]
# Needs root (unshare, nsenter, ip, tc); exits 77 (skipped) without them.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
bin="" out="" domain="" n=3 frames=40 rate_hz=2 cut_s=8 limit_mbit=10
while [ $# -gt 0 ]; do
  case $1 in
    --bin) bin=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --domain) domain=$2; shift 2 ;;
    --vehicles) n=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --rate) rate_hz=$2; shift 2 ;;
    --cut) cut_s=$2; shift 2 ;;
    --limit) limit_mbit=$2; shift 2 ;;
    *) echo "fleet_netns.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[ -n "$bin" ] && [ -n "$out" ] && [ -n "$domain" ] || { echo "usage: see the header" >&2; exit 2; }
if [ "$(id -u)" != 0 ]; then echo "SKIP: needs root for network namespaces"; exit 77; fi
for tool in ip tc unshare nsenter; do
  command -v $tool >/dev/null || { echo "SKIP: $tool missing (iproute2, util-linux)"; exit 77; }
done
export ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE
rm -rf "$out" && mkdir -p "$out"
# shellcheck source=../support/netns.sh
source "$here/../support/netns.sh"   # pids, killed on exit; netns_lan; in_ns
lan_hub="" lan_ns=() lan_dev=()
netns_lan "$n" "fl$$" 10.79.0 || exit 1
if [ "$limit_mbit" != 0 ]; then
  for k in $(seq "$n"); do
    in_ns "${lan_ns[k-1]}" tc qdisc add dev "${lan_dev[k-1]}" root tbf rate "${limit_mbit}mbit" \
      burst 32kbit latency 400ms
  done
fi
stale_s=3
nsenter -t "$lan_hub" -n "$bin/mlmap_fleet" --domain "$domain" --discovery-range SUBNET \
  --stale-after $stale_s --report-every 1 --save-map "$out/fleet.mlmap" > "$out/merger.log" 2>&1 &
merger=$!; pids+=("$merger")
merger_started_s=$(date +%s)
publishers=()
for k in $(seq "$n"); do
  cfg="$out/uav$k.yaml"
  printf 'pipeline: {input_queue_capacity: 64}\ndds:\n  domain_id: %s\n  ns: uav%s\n  fleet: {publish: true, rate_hz: 1.0}\n' \
    "$domain" "$k" > "$cfg"
  nsenter -t "${lan_ns[k-1]}" -n "$bin/mlmap_node" --config "$cfg" --report-every 0 \
    > "$out/node$k.log" 2>&1 &
  pids+=("$!"); nodes[k]=$!
  nsenter -t "${lan_ns[k-1]}" -n "$bin/mlmap_sensor_publisher" --config "$cfg" --prerender \
    --scenario "$src/config/worlds/fleet/uav$(( (k - 1) % 3 + 1 )).yaml" --rate "$rate_hz" --max-frames "$frames" \
    --wait-for-subscriber 30 > "$out/publisher$k.log" 2>&1 &
  pids+=("$!"); publishers+=("$!")
done
for k in $(seq "$n"); do   # the timeline starts when every vehicle streams
  for _ in $(seq 1200); do
    grep -q 'publishing' "$out/publisher$k.log" && break
    sleep 0.1
  done
done
flight_s=$(( frames / rate_hz ))
if [ "$cut_s" != 0 ]; then
  sleep $(( flight_s / 4 ))
  echo "cut: uav1's link down for $cut_s s at $(date +%T)" | tee "$out/cut.log"
  in_ns "${lan_ns[0]}" ip link set "${lan_dev[0]}" down
  sleep "$cut_s"
  grep 'uav1' "$out/merger.log" | tail -n 1 > "$out/during_cut.log"
  in_ns "${lan_ns[0]}" ip link set "${lan_dev[0]}" up
  in_ns "${lan_ns[0]}" ip route add 224.0.0.0/4 dev "${lan_dev[0]}" 2>/dev/null
  echo "cut: restored at $(date +%T)" | tee -a "$out/cut.log"
  sleep $stale_s
  grep 'uav1' "$out/merger.log" | tail -n 1 > "$out/after_cut.log"
fi
pub_rc=0
for p in "${publishers[@]}"; do wait "$p" || pub_rc=1; done
sleep 6   # the last shares (1 Hz) and the retransmissions after the cut
# A merger joining now gets every submap's last state from the writers' histories.
nsenter -t "$lan_hub" -n "$bin/mlmap_fleet" --domain "$domain" --discovery-range SUBNET \
  --duration 10 --report-every 0 > "$out/late.log" 2>&1
late_rc=$?
# The merger's CPU (user + system) and peak resident memory, from /proc before it ends.
read -r -a stat < "/proc/$merger/stat"
ticks=$(getconf CLK_TCK)
merger_cpu_s=$(awk -v u="${stat[13]}" -v s="${stat[14]}" -v t="$ticks" 'BEGIN { printf "%.2f", (u + s) / t }')
merger_hwm_kb=$(awk '/VmHWM/ { print $2 }' "/proc/$merger/status")
merger_wall_s=$(( $(date +%s) - merger_started_s ))
kill -INT "$merger"; wait "$merger"; merger_rc=$?
node_rc=0
for k in $(seq "$n"); do kill -INT "${nodes[k]}"; wait "${nodes[k]}" || node_rc=1; done

for f in merger late; do echo "== $f"; tail -n 4 "$out/$f.log"; done
for k in $(seq "$n"); do echo "== node $k"; grep -E 'done:|fleet:' "$out/node$k.log"; done
fail() { echo "FAIL: $*"; exit 1; }
[ $pub_rc -eq 0 ] || fail "a publisher failed"
[ $node_rc -eq 0 ] && [ $merger_rc -eq 0 ] && [ $late_rc -eq 0 ] || fail "a program failed"
for k in $(seq "$n"); do
  # A flight shorter than --frames publishes all its frames.
  published=$(sed -n 's/.*done: \([0-9]*\) frames published.*/\1/p' "$out/publisher$k.log")
  mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped (\([0-9]*\) dropped.*/\1 \2/p' "$out/node$k.log")
  [ -n "$published" ] && [ "$published" -gt 0 ] || fail "uav$k: no frame published"
  [ "$mapped" = "$published 0" ] ||
    fail "uav$k: onboard mapping disturbed: ${mapped:-no done line} (frames, dropped) of $published published"
done
if [ "$cut_s" != 0 ]; then
  grep -o 'uav1 ([^)]*)' "$out/during_cut.log" | grep -q STALE || fail "uav1 was not marked stale during the cut: $(cat "$out/during_cut.log")"
fi
# The merger's final line: per vehicle "uavK (seen ..., X kB, S submaps, V voxels)" and the merged total.
final=$(grep 'done: ' "$out/merger.log" | tail -n 1)
late=$(grep 'done: ' "$out/late.log" | tail -n 1)
figures() { grep -o 'uav[0-9]* ([^)]*submaps, [0-9]* voxels\|merged [0-9]* voxels' <<<"$1" | sed 's/(seen [^,]*, [^,]*, /(/'; }
echo "merger through the cut: $(figures "$final" | tr '\n' ' ')"
echo "merger joining at the end: $(figures "$late" | tr '\n' ' ')"
[ "$(figures "$final" | sort)" = "$(figures "$late" | sort)" ] || fail "the merged map after the cut differs from the writers' last state"
[ "$(figures "$final" | grep -c '^uav')" = "$n" ] || fail "the merger does not hold $n vehicles"
if [ "$cut_s" != 0 ]; then
  grep -o 'uav1 ([^)]*)' "$out/after_cut.log" | grep -q STALE &&
    fail "uav1 still stale after its link came back: $(cat "$out/after_cut.log")"
fi
# What the merger saved as it stopped is the map it held (mlmap_map_tool reads it as any map).
saved=$("$bin/mlmap_map_tool" --info "$out/fleet.mlmap" | sed -n 's/.*global map: \([0-9]*\) occupied voxels.*/\1/p')
merged=$(grep -o 'merged [0-9]* voxels' <<<"$final" | grep -o '[0-9]*')
[ -n "$saved" ] && [ "$saved" = "$merged" ] ||
  fail "the saved merged map holds ${saved:-no} voxels, the merger $merged"
echo "saved: $out/fleet.mlmap, $saved occupied voxels"
echo "merger: ${merger_cpu_s} s of CPU over ${merger_wall_s} s, peak RSS $(( merger_hwm_kb / 1024 )) MB, $n vehicles at $rate_hz Hz"
echo "PASS"
