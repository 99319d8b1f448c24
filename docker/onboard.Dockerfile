# Onboard image: Debian 12 with Debian packages only, no ROS: mlmap_node alone, which speaks ROS 2
# Jazzy's wire format over plain Fast DDS 2.9 (rt/ topics, ROS type names). Two stages:
# - build: tools/install_deps.sh --onboard and a Release build of mlmap_node alone, without the
#   offline programs (-DMLMAP_BUILD_APPS=OFF), so neither OpenCV nor OctoMap is installed;
# - the image: a bare Debian 12 with the runtime libraries mlmap_node loads (the packages
#   docker/runtime_packages.sh finds with ldd in the build stage), the program and config/: no
#   compiler, no -dev package.
# docker/sim.Dockerfile starts with the build stage's instructions, unchanged, so that a builder
# with a layer cache (podman, Docker) compiles the node's libraries once for both images.
# Build from the repository root:
#   docker build -f docker/onboard.Dockerfile -t mlmap-onboard .
#   podman build --network host -f docker/onboard.Dockerfile -t mlmap-onboard .
#      (tools/container_images.sh: podman, with a Debian 12 base image of its own, no registry)
# Run the node on the host's network (ROS 2 peers there see /mlmap/... topics):
#   docker run --rm --network host -e ROS_DOMAIN_ID=0 mlmap-onboard
# docker/compose.yaml runs this image as the node (docker/sim.Dockerfile is the simulated sensor);
# tests/integration/containers_podman.sh runs it with podman, and checks what it holds.
FROM debian:12 AS build
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
COPY docker/runtime_packages.sh docker/runtime_packages.sh
RUN bash docker/runtime_packages.sh build/mlmap_node > build/runtime_packages.txt

FROM debian:12
WORKDIR /opt/mlmap
COPY --from=build /opt/mlmap/build/runtime_packages.txt /tmp/runtime_packages.txt
RUN apt-get update -qq \
 && xargs -a /tmp/runtime_packages.txt env DEBIAN_FRONTEND=noninteractive \
      apt-get install -y -qq --no-install-recommends \
 && rm -rf /var/lib/apt/lists/* /tmp/runtime_packages.txt
COPY --from=build /opt/mlmap/build/mlmap_node bin/mlmap_node
COPY config ./config
ENV PATH=/opt/mlmap/bin:$PATH
# ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE and FASTRTPS_DEFAULT_PROFILES_FILE work as for a
# ROS 2 node; the config's dds section sets topics, frames and rates.
CMD ["mlmap_node", "--config", "config/mlmap_node.yaml"]
