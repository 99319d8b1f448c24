# Onboard image: Debian 12 with Debian packages only, no ROS: mlmap_node alone, which speaks ROS 2
# Jazzy's wire format over plain Fast DDS 2.9 (rt/ topics, ROS type names). It is built without
# the offline programs (-DMLMAP_BUILD_APPS=OFF), so neither OpenCV nor OctoMap is installed.
# Build from the repository root:
#   docker build -f docker/onboard.Dockerfile -t mlmap-onboard .
# Run the node on the host's network (ROS 2 peers there see /mlmap/... topics):
#   docker run --rm --network host -e ROS_DOMAIN_ID=0 mlmap-onboard
# docker/compose.yaml runs this image as the node (docker/sim.Dockerfile is the simulated sensor).
#
# No Docker engine runs on the project's CI machines, so this file is checked by reading and by
# tests/ros2/test_ground_station_files.py: it installs with tools/install_deps.sh --onboard and
# copies everything the CMakeLists.txt files read.
FROM debian:12
WORKDIR /opt/mlmap
# Packages first, so that a source change does not reinstall them.
COPY tools/install_deps.sh tools/install_deps.sh
RUN bash tools/install_deps.sh --onboard && rm -rf /var/lib/apt/lists/*
COPY CMakeLists.txt ./
COPY cmake ./cmake
COPY idl ./idl
COPY include ./include
COPY src ./src
COPY config ./config
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_APPS=OFF -DMLMAP_BUILD_TESTS=OFF -DMLMAP_BUILD_DDS=ON \
 && cmake --build build -j2 --target mlmap_node
ENV PATH=/opt/mlmap/build:$PATH
# ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE and FASTRTPS_DEFAULT_PROFILES_FILE work as for a
# ROS 2 node; the config's dds section sets topics, frames and rates.
CMD ["mlmap_node", "--config", "config/mlmap_node.yaml"]
