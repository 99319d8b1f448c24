# Simulation image: Debian 12 with Debian packages only, no ROS: the simulated depth camera
# (mlmap_sensor_publisher), the mapping demo and the inspector, built as tools/demo.sh builds
# them. Build from the repository root:
#   docker build -f docker/sim.Dockerfile -t mlmap-sim .
# The mapping demo (pictures into ./demo_output):
#   docker run --rm -v "$PWD/demo_output:/out" mlmap-sim mlmap_demo --out /out
# docker/compose.yaml runs this image as the simulated sensor.
#
# No Docker engine runs on the project's CI machines, so this file is checked by reading and by
# tests/ros2/test_ground_station_files.py: it installs with tools/install_deps.sh --programs,
# configures and builds with the commands of tools/demo.sh, and copies everything the
# CMakeLists.txt files read.
FROM debian:12
WORKDIR /opt/mlmap
COPY tools/install_deps.sh tools/install_deps.sh
RUN bash tools/install_deps.sh --programs && rm -rf /var/lib/apt/lists/*
COPY CMakeLists.txt ./
COPY cmake ./cmake
COPY idl ./idl
COPY include ./include
COPY src ./src
COPY tests ./tests
COPY config ./config
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_TESTS=OFF -DMLMAP_BUILD_DDS=ON \
 && cmake --build build -j2 --target mlmap_demo mlmap_node mlmap_sensor_publisher mlmap_inspect
ENV PATH=/opt/mlmap/build:$PATH
CMD ["mlmap_sensor_publisher", "--config", "config/mlmap_node.yaml"]
