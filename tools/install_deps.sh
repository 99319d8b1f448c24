#!/usr/bin/env bash
# Installs the Debian 12 packages mlmap needs, only those that are missing (apt-get, through sudo
# when not root). Safe to run again: it does nothing when everything is there.
set -euo pipefail

packages=(
  g++ make cmake                       # toolchain
  libeigen3-dev                        # mapping core
  libyaml-cpp-dev                      # configuration files
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev  # depth PNGs, map pictures
  libcli11-dev libspdlog-dev           # command line, logging
  libgtest-dev                         # tests
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools  # DDS component (Fast DDS 2.9, ROS 2 wire types)
  cyclonedds-dev cyclonedds-tools      # cross-vendor interoperability test (ROS 2's other tier-1 DDS)
  iproute2                             # network-namespace tests
)

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
