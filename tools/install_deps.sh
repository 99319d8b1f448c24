#!/usr/bin/env bash
# Installs the Debian 12 packages mlmap needs, only those that are missing (apt-get, through sudo
# when not root). Safe to run again: it does nothing when everything is there.
#   bash tools/install_deps.sh             everything: build, tests, ground-station tools' tests
#   bash tools/install_deps.sh --programs  the programs without their tests (docker/sim.Dockerfile)
#   bash tools/install_deps.sh --onboard   mlmap_node alone (docker/onboard.Dockerfile): no OpenCV,
#                                          no OctoMap (cmake -DMLMAP_BUILD_APPS=OFF)
#   bash tools/install_deps.sh --containers  podman and what the containerized integration test
#                                          needs to make its base image (tools/container_images.sh)
set -euo pipefail
case "${1:-}" in
  "" | --programs | --onboard | --containers) ;;
  *) echo "usage: $0 [--programs | --onboard | --containers]" >&2; exit 2 ;;
esac

# mlmap_node: the core, the configuration, map files and the DDS component.
packages=(
  g++ make cmake ninja-build           # toolchain (Ninja builds the test command's trees)
  libeigen3-dev                        # mapping core
  libyaml-cpp-dev                      # configuration files
  libcli11-dev libspdlog-dev           # command line, logging
  libfastrtps-dev libfastcdr-dev fastddsgen  # DDS component (Fast DDS 2.9, ROS 2 wire types)
  libzstd-dev                          # the fleet's shared submaps (mlmap_node, mlmap_fleet)
  python3                              # the build: the IDL's type hashes and CDR layouts (tools/idl_*.py)
)
# The offline programs (demo, replay, map tool, sensor publisher, inspector, benchmarks).
programs=(
  libopencv-core-dev libopencv-imgproc-dev  # map pictures
  libpng-dev                           # depth PNGs, map pictures (PNG through libpng)
  liboctomap-dev                       # OctoMap: .bt export (mlmap_map_tool), the side-by-side comparison
  libdynamicedt3d-dev                  # DynamicEDT3D: the ESDF benchmark's side-by-side comparison
  fastdds-tools                        # `fastdds discovery` (config/dds/discovery_server_client.xml)
  nlohmann-json3-dev                   # JSON files: report.json, stats.json, summary.json
  libzstd-dev liblz4-dev libsqlite3-dev  # ROS 2 bags: MCAP chunks (zstd, lz4), sqlite3 .db3 files
)
# The tests and their tools.
test_tools=(
  libgtest-dev                         # tests
  libopencv-imgcodecs-dev              # the tests' independent PNG reader and writer
  clang libclang-rt-14-dev llvm-14     # fuzzing: libFuzzer + sanitizer runtimes, llvm-symbolizer (tools/fuzz.sh)
  clang-tidy cppcheck clang-format     # static analysis and the C++ layout (tools/lint.sh)
  cyclonedds-dev cyclonedds-tools      # cross-vendor interoperability test (ROS 2's other tier-1 DDS)
  iproute2                             # network-namespace tests
  openssl                              # DDS Security: test keystores (tools/make_test_keystore.sh); python3 runs the capture test
)
# The ROS 2 ground-station tools (tools/ros2, docker/): no ROS in Debian 12, so their tests run
# the ROS-free parts under /usr/bin/python3 and lint the rest.
ground_tools=(
  python3-numpy python3-pytest python3-yaml  # bridge conversions, checker logic and their tests
  python3-rosidl                       # .msg and IDL parsers: the mlmap_msgs parity test
  python3-catkin-pkg python3-setuptools  # package.xml checks
  colcon python3-colcon-ros python3-colcon-package-information  # colcon discovery (list) and install
  python3-flake8 pydocstyle shellcheck  # lint (the ament flake8 / pep257 rules)
  python3-matplotlib                   # the charts of the OctoMap comparison (tools/plot_octomap_comparison.py)
)
# The containerized integration test (tests/integration/containers_podman.sh): Debian's podman
# with runc (crun refuses a cgroup v1 hybrid layout), debootstrap for the local Debian 12 base
# image (no registry), iproute2 for the network namespaces the containers run in.
containers=(podman runc debootstrap iproute2)
case "${1:-}" in
  --onboard) ;;
  --programs) packages+=("${programs[@]}") ;;
  --containers) packages=("${containers[@]}") ;;
  *) packages+=("${programs[@]}" "${test_tools[@]}" "${ground_tools[@]}") ;;
esac

# Node.js and npm write the ROS 2 test bags (tests/bag/fixtures, `npm ci` of its lockfile): the
# machine's own when there (a Node.js build that bundles npm conflicts with Debian's npm
# package), Debian's otherwise.
if [ -z "${1:-}" ]; then
  command -v node >/dev/null || packages+=(nodejs)
  command -v npm >/dev/null || packages+=(npm)
fi

missing=()
for p in "${packages[@]}"; do
  if [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" != "install ok installed" ]; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
echo "installing missing packages: ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
