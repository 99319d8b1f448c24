#!/usr/bin/env bash
# The containerized integration test, run for real with podman: the images of docker/ built on
# this machine (tools/container_images.sh: a local Debian 12 base, no registry), and three
# containers, each in a network namespace of this test's own, with the shipped Fast DDS profile
# (config/dds/udp_only.xml, as docker/compose.yaml sets it):
#
#   [sensor] mlmap-sim: mlmap_sensor_publisher, the built-in room's flight as depth images
#      |  vehicle link (veth, 10.211.1.0/24)
#   [node]   mlmap-onboard: mlmap_node, its map saved on SIGTERM to a mounted folder
#      |  ground link (veth, 10.211.2.0/24)
#   [ground] mlmap-sim: mlmap_inspect as the ground station's checker
#
# Multicast discovery stays on the two links: the containers never see the host's interfaces,
# so no DDS traffic reaches the real network. Passes when every layer reaches the ground, the
# node maps every frame sent, the received occupied voxels agree with the simulator's ground
# truth (precision >= 0.9) and the latched global map with the node's, every container stops by
# itself or on `podman stop` with exit code 0, the node's final map is in the mounted folder and
# mlmap_map_tool reads it (its frames and global voxels are the node's), and the onboard image
# holds no OpenCV, OctoMap or compiler. Prints the images' sizes and the test's duration.
# The ROS 2 ground image (ros:jazzy) needs a registry with ROS 2: not built here (docker/compose.yaml
# and docker/run_integration_test.sh run it where Docker and the registry are).
#   bash tests/integration/containers_podman.sh [--out DIR]   (default build-containers/test)
# tools/test.sh runs it as its last part. Needs root (podman, network namespaces); DDS domain 211.
# Exits 0 with a line saying SKIP where podman cannot start a container at all.
set -uo pipefail
cd "$(dirname "$0")/../.." || exit 1
out=build-containers/test
case "${1:-}" in
  "") ;;
  --out) out=${2:?--out needs a folder} ;;
  *) echo "usage: $0 [--out DIR]" >&2; exit 2 ;;
esac
domain=211 frames=40
[ "$(id -u)" = 0 ] || { echo "FAIL: needs root (podman, network namespaces)"; exit 1; }
start=$SECONDS

echo "== 1. the images (tools/container_images.sh)"
mkdir -p "$out"
images_rc=0
bash tools/container_images.sh --env "$out/images.env" || images_rc=$?
if [ $images_rc -eq 77 ]; then exit 0; fi   # podman cannot start a container here: said why
[ $images_rc -eq 0 ] || { echo "FAIL: the images could not be built"; exit 1; }
onboard=$(sed -n 's/^onboard=//p' "$out/images.env") sim=$(sed -n 's/^sim=//p' "$out/images.env")
images_s=$((SECONDS - start))
export CONTAINERS_CONF=$PWD/docker/podman/containers.conf
pm() { podman --runtime runc --cgroup-manager=cgroupfs "$@"; }

echo "== 2. three containers in three network namespaces (domain $domain)"
rm -rf "$out/run" && mkdir -p "$out/run/cfg" "$out/run/map" "$out/run/ground"
run=$(cd "$out/run" && pwd)
names=(sensor node ground)
prefix=mlmap$$
# shellcheck source=../support/netns.sh
source tests/support/netns.sh   # pids, killed on exit; netns_new; in_ns
netns_pid=""
cleanup() {
  for n in "${names[@]}"; do pm rm -f "$prefix-$n" > /dev/null 2>&1; done
  netns_cleanup
}
trap cleanup EXIT
netns_new; sensor_ns=$netns_pid
netns_new; node_ns=$netns_pid
netns_new; ground_ns=$netns_pid
# link NS_A DEV_A ADDR_A NS_B DEV_B ADDR_B: a veth pair between two namespaces, multicast on
# and routed to it on side A's (and B's, when B has no other link: the node keeps its route on
# the vehicle link, and Fast DDS sends its discovery out of every interface).
link() {
  ip link add "$2" type veth peer name "$5" &&
  ip link set "$2" netns "$1" && ip link set "$5" netns "$4" &&
  in_ns "$1" ip addr add "$3/24" dev "$2" && in_ns "$4" ip addr add "$6/24" dev "$5" &&
  for side in "$1:$2" "$4:$5"; do
    in_ns "${side%%:*}" ip link set lo up && in_ns "${side%%:*}" ip link set "${side#*:}" up multicast on || return 1
  done
}
link "$sensor_ns" "${prefix}s" 10.211.1.1 "$node_ns" "${prefix}v" 10.211.1.2 &&
link "$node_ns" "${prefix}g" 10.211.2.1 "$ground_ns" "${prefix}r" 10.211.2.2 &&
in_ns "$sensor_ns" ip route add 224.0.0.0/4 dev "${prefix}s" &&
in_ns "$node_ns" ip route add 224.0.0.0/4 dev "${prefix}v" &&
in_ns "$ground_ns" ip route add 224.0.0.0/4 dev "${prefix}r" ||
  { echo "FAIL: could not make the links"; exit 1; }

# The configuration (as tests/dds/e2e_loopback.sh in depth mode: a 9 m window, so that the
# flight retires submaps into the global map, and a long input queue, so that a loaded machine
# delays frames rather than dropping them); the node's also saves its map to the mounted folder
# on SIGTERM.
{
  printf 'local_map: {size_cells: [45, 45, 25]}\npipeline: {input_queue_capacity: 64}\n'
  cat config/mlmap_node_depth.yaml
} > "$run/cfg/flight.yaml"
{
  printf 'map_file: {save_path: /map/final.mlmap}\n'
  cat "$run/cfg/flight.yaml"
} > "$run/cfg/node.yaml"
# docker/compose.yaml's DDS environment (x-dds-environment), with this test's domain.
dds_env=(-e "ROS_DOMAIN_ID=$domain" -e ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET
         -e RMW_IMPLEMENTATION=rmw_fastrtps_cpp
         -e FASTRTPS_DEFAULT_PROFILES_FILE=/opt/mlmap/config/dds/udp_only.xml)
# container NAME NAMESPACE_HOLDER IMAGE VOLUME ARGS...: started in the background, in that
# namespace, with the configuration's folder (read only) and VOLUME ("" for none) mounted.
container() {
  local name=$1 ns=$2 image=$3 volume=(-v "$run/cfg:/cfg:ro")
  [ -z "$4" ] || volume+=(-v "$4")
  shift 4
  pm run -d --name "$prefix-$name" --network "ns:/proc/$ns/ns/net" "${dds_env[@]}" \
    "${volume[@]}" "$image" "$@" > /dev/null
}
flight_start=$SECONDS
container node "$node_ns" "$onboard" "$run/map:/map" mlmap_node --config /cfg/node.yaml --report-every 1 ||
  { echo "FAIL: the node's container did not start"; exit 1; }
container ground "$ground_ns" "$sim" "$run/ground:/ground" mlmap_inspect --config /cfg/flight.yaml \
  --out /ground --expect-all --default-scenario --min-precision 0.9 --idle-stop 3 --duration 180 ||
  { echo "FAIL: the ground station's container did not start"; exit 1; }
container sensor "$sensor_ns" "$sim" "" mlmap_sensor_publisher --config /cfg/flight.yaml --mode depth \
  --max-frames $frames --rate 20 --speed 4 --wait-for-subscriber 60 ||
  { echo "FAIL: the sensor's container did not start"; exit 1; }
# What the node's container sees of the network: its two links and loopback, nothing of the host.
node_links=$(pm exec "$prefix-node" cat /proc/net/dev | awk -F: 'NR > 2 { gsub(/ /, "", $1); print $1 }' | sort | xargs)

exit_code() { pm wait "$prefix-$1" 2>/dev/null | tail -n 1; }
sensor_rc=$(exit_code sensor)
sleep 2   # the last frames' layers cross
pm stop -t 30 "$prefix-node" > /dev/null
node_rc=$(exit_code node)
ground_rc=$(exit_code ground)   # stops 3 s after the node went quiet (--idle-stop)
flight_s=$((SECONDS - flight_start))
for n in "${names[@]}"; do pm logs "$prefix-$n" > "$run/$n.log" 2>&1; done
for n in "${names[@]}"; do echo "== $n ($n.log)"; cat "$run/$n.log"; done
echo "exit codes: sensor ${sensor_rc:-?}, node ${node_rc:-?}, ground ${ground_rc:-?}"

echo "== 3. the node's final map, read by mlmap_map_tool (the simulation image)"
pm run --rm --network none -v "$run/map:/map:ro" "$sim" mlmap_map_tool /map/final.mlmap --info \
  > "$run/map_tool.log" 2>&1
map_tool_rc=$?
cat "$run/map_tool.log"

echo "== 4. what the onboard image holds"
# Compilers anywhere on PATH or in dpkg's list; OpenCV or OctoMap as a package or a library.
pm run --rm --network none "$onboard" sh -c '
  for c in cc c++ gcc g++ clang clang++ cpp; do command -v "$c"; done
  dpkg-query -W -f="\${Package}\n" | grep -E "^(gcc|g\+\+|clang|cpp)(-[0-9]+)?$|opencv|octomap"
  find / -xdev \( -name "libopencv*" -o -name "liboctomap*" -o -name "*-linux-gnu-g*" \) -print
  true' > "$run/onboard_contents.log" 2>&1
onboard_rc=$?
onboard_bytes=$(pm image inspect --format '{{.Size}}' "$onboard")
sim_bytes=$(pm image inspect --format '{{.Size}}' "$sim")
onboard_packages=$(pm run --rm --network none "$onboard" sh -c 'dpkg-query -W | wc -l')

fail() { echo "FAIL: $*"; exit 1; }
echo "node's network interfaces: $node_links"
[ "$node_links" = "$(printf '%s\n' lo "${prefix}v" "${prefix}g" | sort | xargs)" ] || fail "the node's container sees other interfaces: $node_links"
[ "$sensor_rc" = 0 ] && [ "$node_rc" = 0 ] && [ "$ground_rc" = 0 ] ||
  fail "a container did not stop cleanly (exit codes: sensor ${sensor_rc:-?}, node ${node_rc:-?}, ground ${ground_rc:-?})"
grep -q "done: $frames frames published" "$run/sensor.log" || fail "the sensor did not send its $frames frames"
grep -q "done: $frames frames mapped (0 dropped" "$run/node.log" ||
  fail "frames mapped != frames sent ($frames): $(grep 'done: ' "$run/node.log")"
for f in dds_map_top.png dds_awareness_top.png dds_grid.png dds_esdf_slice.png summary.json; do
  [ -s "$run/ground/$f" ] || fail "the ground station wrote no $f"
done
precision=$(sed -n 's/.*precision against the scenario: \([0-9.]*\).*/\1/p' "$run/ground.log")
global=$(sed -n 's/.*"mlmap\/global_map\/occupied": {.*"last_points": \([0-9]*\)}.*/\1/p' "$run/ground/summary.json")
node_global=$(sed -n 's/.*"node_global_voxels": \([0-9]*\).*/\1/p' "$run/ground/summary.json")
echo "ground truth: precision ${precision:-?} of the received occupied voxels (>= 0.9)"
echo "global map: ${global:-none} voxels received at the ground, the node reported ${node_global:-?}"
[ "${global:-0}" -gt 0 ] && [ "$global" = "$node_global" ] || fail "the global map received is not the node's"
saved=$(grep -o "shutdown: saved the map to '/map/final.mlmap' .*" "$run/node.log")
[ -n "$saved" ] && [ -s "$run/map/final.mlmap" ] || fail "the node saved no final map to the mounted folder"
saved_global=$(sed -n 's/.*, \([0-9]*\) global voxels).*/\1/p' <<<"$saved")
file_frames=$(sed -n 's/.*; \([0-9]*\) frames mapped.*/\1/p' "$run/map_tool.log")
file_global=$(sed -n 's/.*global map: \([0-9]*\) occupied voxels.*/\1/p' "$run/map_tool.log")
[ $map_tool_rc -eq 0 ] && [ "${file_frames:-0}" -eq $frames ] && [ "${file_global:--1}" = "${saved_global:--2}" ] ||
  fail "mlmap_map_tool: the saved map holds ${file_frames:-no} frames and ${file_global:-no} global voxels (the node: $frames, ${saved_global:-?})"
echo "saved map: $(stat -c %s "$run/map/final.mlmap") bytes, $file_frames frames, $file_global global voxels"
[ $onboard_rc -eq 0 ] || fail "could not look into the onboard image"
[ ! -s "$run/onboard_contents.log" ] || { cat "$run/onboard_contents.log"; fail "the onboard image holds a compiler, OpenCV or OctoMap"; }
echo "onboard image: no compiler, no OpenCV, no OctoMap; $onboard_packages packages"
echo "image sizes: $onboard $((onboard_bytes / 1000000)) MB, $sim $((sim_bytes / 1000000)) MB"
echo "time: images ${images_s} s, flight and stop ${flight_s} s, whole test $((SECONDS - start)) s"
echo "PASSED: the containerized integration test"
