#!/usr/bin/env bash
# The main job: installs what is missing, builds (Release) and runs
#  1. the mapping demo on the built-in simulated room: pictures, accuracy, timings and memory in
#     demo_output/;
#  2. the same flight over DDS on loopback, as on a vehicle: mlmap_sensor_publisher (simulated
#     depth camera + odometry) -> mlmap_node -> mlmap_inspect, which writes pictures of the layers
#     it received and summary.json to demo_output/dds/.
# Extra arguments go to mlmap_demo (see `build/mlmap_demo --help`), e.g.
#   bash tools/demo.sh --frames ../shared/data/realsense_tabletop
# With --fleet N (1 .. 3) it instead flies N vehicles at once through the building
# (config/worlds/fleet/uav1..N.yaml), each with its own engine sharing its submaps as mlmap_node
# does, merged as mlmap_fleet merges them (in one process, no DDS: docs/fleet.md), and writes
# fleet_output/: fleet_top.png (the merged map coloured by vehicle), <vehicle>_top.png and
# summary.json. Further arguments go to mlmap_fleet_demo (`build/mlmap_fleet_demo --help`).
# With --navigate it instead flies the reference planner (mlmap_nav) on mlmap's maps through
# seeded unknown worlds (forests, rooms joined by doors, the paper's room; a person crossing in
# some), in one process, and writes nav_output/: a picture per world (the map, the ground truth,
# the path flown, the goal, where a new frame made it plan at once) and summary.json
# (docs/planners.md, "Flying on mlmap"). Further arguments go to mlmap_navigate
# (`build/mlmap_navigate --help`), e.g. --worlds 20.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_TESTS=OFF -DMLMAP_BUILD_DDS=ON >/dev/null
cmake --build build -j2 --target mlmap_demo mlmap_node mlmap_sensor_publisher mlmap_inspect
if [ "${1:-}" = --navigate ]; then
  shift
  cmake --build build -j2 --target mlmap_navigate
  ./build/mlmap_navigate --out nav_output "$@"
  exit 0
fi
if [ "${1:-}" = --fleet ]; then
  vehicles=${2:-}
  case "$vehicles" in
    1|2|3) ;;
    *) echo "demo.sh: --fleet takes the number of vehicles, 1 to 3 (config/worlds/fleet/uav1..3.yaml)" >&2
       exit 2 ;;
  esac
  shift 2
  cmake --build build -j2 --target mlmap_fleet_demo
  scenarios=()
  for k in $(seq "$vehicles"); do scenarios+=(--scenario "config/worlds/fleet/uav$k.yaml"); done
  ./build/mlmap_fleet_demo "${scenarios[@]}" --out fleet_output "$@"
  exit 0
fi
./build/mlmap_demo --out demo_output "$@"

echo "== the same flight over DDS (loopback only, domain ${MLMAP_DEMO_DOMAIN:-42})"
export ROS_DOMAIN_ID=${MLMAP_DEMO_DOMAIN:-42} ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
mkdir -p demo_output/dds
./build/mlmap_node --report-every 5 > demo_output/dds/node.log 2>&1 &
node=$!
./build/mlmap_inspect --out demo_output/dds --default-scenario --idle-stop 3 --duration 300 \
  > demo_output/dds/inspect.log 2>&1 &
inspect=$!
trap 'kill $node $inspect 2>/dev/null || true' EXIT
./build/mlmap_sensor_publisher
kill -INT $node && wait $node || true
wait $inspect || true
tail -n 12 demo_output/dds/node.log demo_output/dds/inspect.log
echo "pictures of the layers received over DDS: demo_output/dds/*.png"
