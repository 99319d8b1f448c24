#!/usr/bin/env bash
# Map-to-plan latency over DDS: the reference planner as a DDS peer (mlmap_planner_peer) flies
# worlds of nav_worlds with mlmap_node and the closed-loop sensor publisher, three processes on
# loopback, and this prints per world whether the goal was reached and with how many collisions,
# and over all worlds the map-to-plan latency (a frame's capture stamp to the publication of the
# nav_msgs/Path planned on the map state that frame ended: median, p99, max, by nearest rank as
# every mlmap figure) and the part of it before the ESDF reached the planner. The planner reads the
# camera's clouds too (--cloud-topic), as the person test does. Figures, not a test.
#
#   tools/bench_nav_dds.sh [--build DIR] [--out DIR] [--resolution M] [--worlds "LIST"]
#                          [--domain ID]
#
#   --build DIR       where the programs are (default: build)
#   --out DIR         logs and configurations (default: bench_output/nav_dds)
#   --resolution M    voxel edge: 0.1 (default; config/mlmap_node_nav.yaml) or 0.2
#   --worlds LIST     kind:seed of each flight, kind forest (0.08 trees / m^2, 14 x 8 m), rooms
#                     (2 rooms) or paper (default: "forest:21 forest:22 forest:23 rooms:24 paper:25")
#   --domain ID       DDS domain (default 224)
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=build out=bench_output/nav_dds resolution=0.1 domain=224
worlds="forest:21 forest:22 forest:23 rooms:24 paper:25"
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --resolution) resolution=$2; shift 2 ;;
    --worlds) worlds=$2; shift 2 ;;
    --domain) domain=$2; shift 2 ;;
    *) echo "unknown argument $1" >&2; exit 2 ;;
  esac
done
export ROS_DOMAIN_ID=$domain
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE
mkdir -p "$out"
cfg="$out/node.yaml"
case $resolution in
  0.1) cp "$here/../config/mlmap_node_nav.yaml" "$cfg" ;;
  0.2) sed -e 's/resolution_m: 0.1/resolution_m: 0.2/' -e 's/\[190, 190, 70\]/[95, 95, 35]/' \
         "$here/../config/mlmap_node_nav.yaml" > "$cfg" ;;
  *) echo "--resolution: 0.1 or 0.2" >&2; exit 2 ;;
esac
: > "$out/latency_ms.txt"
for world in $worlds; do
  kind=${world%%:*} seed=${world##*:}
  log="$out/$kind$seed"
  "$build/mlmap_node" --config "$cfg" --report-every 0 > "$log.node.log" 2>&1 &
  node=$!
  "$build/mlmap_planner_peer" --config "$cfg" --report-every 0 --latency-out "$log.latency_ms.txt" \
    --cloud-topic cloud > "$log.planner.log" 2>&1 &
  planner=$!
  "$build/mlmap_sensor_publisher" --config "$cfg" --closed-loop "$kind" --world-seed "$seed" \
    --timeout 90 --wait-for-subscriber 20 > "$log.publisher.log" 2>&1
  kill -INT $planner; wait $planner
  kill -INT $node; wait $node
  result=$(sed -n 's/.*closed loop: \(reached [01], collisions [0-9]*\).*/\1/p' "$log.publisher.log")
  p99=$(sed -n 's/.*map-to-plan (over DDS) median \([0-9.]* ms p99 [0-9.]* ms\).*/\1/p' \
    "$log.planner.log")
  echo "$kind:$seed  ${result:-no result (see $log.publisher.log)}  map-to-plan median ${p99:-?}"
  cat "$log.latency_ms.txt" >> "$out/latency_ms.txt"
done
summary() {  # median, p99 and max of the values in $1, nearest rank (sortedQuantile's rule)
  sort -g "$1" | awk '{ v[NR - 1] = $1 } END {
    if (NR == 0) { print "no samples"; exit }
    m = int(0.5 * (NR - 1) + 0.5); p = int(0.99 * (NR - 1) + 0.5)
    printf "median %.1f ms  p99 %.1f ms  max %.1f ms (%d maps)\n", v[m], v[p], v[NR - 1], NR }'
}
echo "map-to-plan over DDS at $resolution m, all worlds: $(summary "$out/latency_ms.txt")"
