# Simulation image: Debian 12 with Debian packages only, no ROS: the simulated depth camera
# (mlmap_sensor_publisher), the mapping demo, the inspector and the map tool, configured and
# built as tools/demo.sh does (plus mlmap_map_tool). Build from the repository root:
#   docker build -f docker/sim.Dockerfile -t mlmap-sim .
#   podman build --network host -f docker/sim.Dockerfile -t mlmap-sim .
# The mapping demo (pictures into ./demo_output):
#   docker run --rm -v "$PWD/demo_output:/out" mlmap-sim mlmap_demo --out /out
# docker/compose.yaml runs this image as the simulated sensor; tests/integration/containers_podman.sh
# as the sensor, the ground station's inspector and the reader of the node's saved map.
#
# The first instructions are docker/onboard.Dockerfile's build stage, unchanged (a test keeps
# them equal): a builder with a layer cache reuses that stage's layers, mlmap_node's libraries
# included, and this image adds the offline programs' packages and their own code only.
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
# The build runs these for the IDL's ROS 2 type hashes and CDR layouts.
COPY tools/idl_type_hashes.py tools/idl_cdr_layouts.py ./tools/
COPY config ./config
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_APPS=OFF -DMLMAP_BUILD_TESTS=OFF -DMLMAP_BUILD_DDS=ON \
 && cmake --build build -j2 --target mlmap_node
# The offline programs: their packages, tests/benchmarks (built with the programs; the image builds
# no test), and the same tree configured again with them on: mlmap_node's objects are kept.
RUN bash tools/install_deps.sh --programs && rm -rf /var/lib/apt/lists/*
COPY tests/benchmarks ./tests/benchmarks
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_TESTS=OFF -DMLMAP_BUILD_DDS=ON -DMLMAP_BUILD_APPS=ON \
 && cmake --build build -j2 --target mlmap_demo mlmap_node mlmap_sensor_publisher mlmap_inspect mlmap_map_tool
ENV PATH=/opt/mlmap/build:$PATH
CMD ["mlmap_sensor_publisher", "--config", "config/mlmap_node.yaml"]
