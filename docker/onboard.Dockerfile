# Onboard image: Debian 12 with Debian packages only (no ROS). Builds mlmap and runs the demo;
# later the DDS node. Build from the repository root:
#   docker build -f docker/onboard.Dockerfile -t mlmap-onboard .
#   docker run --rm -v "$PWD/demo_output:/out" mlmap-onboard
# (No Docker engine runs on the project's CI machines; this file is kept in step with
# tools/demo.sh, which CI exercises.)
FROM debian:12
WORKDIR /opt/mlmap
COPY CMakeLists.txt ./
COPY cmake ./cmake
COPY include ./include
COPY src ./src
COPY tests ./tests
COPY config ./config
COPY tools ./tools
RUN bash tools/install_deps.sh \
 && cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_TESTS=OFF \
 && cmake --build build -j2 --target mlmap_demo \
 && rm -rf /var/lib/apt/lists/*
ENTRYPOINT ["/opt/mlmap/build/mlmap_demo"]
CMD ["--out", "/out"]
