# Onboard image: Debian 12 with Debian packages only, no ROS. Builds mlmap and runs mlmap_node,
# which speaks ROS 2 Jazzy's wire format over plain Fast DDS 2.9 (rt/ topics, ROS type names).
# Build from the repository root:
#   docker build -f docker/onboard.Dockerfile -t mlmap-onboard .
# Run the node on the host's network (ROS 2 peers there see /mlmap/... topics):
#   docker run --rm --network host -e ROS_DOMAIN_ID=0 mlmap-onboard
# Or the mapping demo (pictures into ./demo_output):
#   docker run --rm -v "$PWD/demo_output:/out" mlmap-onboard mlmap_demo --out /out
# docker/compose.yaml runs this image as the simulated sensor and as the node.
#
# No Docker engine runs on the project's CI machines, so this file is checked by reading and by
# tests/ros2/test_ground_station_files.py: it installs with tools/install_deps.sh, configures and
# builds with the commands of tools/demo.sh, and copies everything CMakeLists.txt reads.
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
COPY tests ./tests
COPY config ./config
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_TESTS=OFF \
 && cmake --build build -j2 --target mlmap_demo mlmap_node mlmap_sensor_publisher mlmap_inspect
ENV PATH=/opt/mlmap/build:$PATH
# ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE and FASTRTPS_DEFAULT_PROFILES_FILE work as for a
# ROS 2 node; the config's dds section sets topics, frames and rates.
CMD ["mlmap_node", "--config", "config/mlmap_node.yaml"]
