# Ground-station image: ROS 2 Jazzy with mlmap's ROS 2 packages (tools/ros2: mlmap_msgs and
# mlmap_bridge). Runs the bridge headless; `ros2 run mlmap_bridge mlmap_check` is the checker of
# the container integration test (docker/compose.yaml, docker/run_integration_test.sh).
# Build from the repository root:
#   docker build -f docker/ground.Dockerfile -t mlmap-ground .
#
# No Docker engine runs on the project's CI machines, so this file is checked by reading and by
# tests/ros2/test_ground_station_files.py; the bridge's unit tests run in CI, and run again here
# (colcon test) against Jazzy's own Python and numpy.
FROM ros:jazzy
SHELL ["/bin/bash", "-o", "pipefail", "-c"]
WORKDIR /opt/mlmap_ws
COPY tools/ros2 src/mlmap_ros2
# The packages' dependencies from their package.xml; RViz2 is left out (no display here).
RUN apt-get update \
 && rosdep update --rosdistro jazzy \
 && rosdep install --from-paths src --ignore-src -y --rosdistro jazzy --skip-keys rviz2 \
 && rm -rf /var/lib/apt/lists/*
RUN source /opt/ros/jazzy/setup.bash \
 && colcon build --event-handlers console_direct+ \
 && colcon test --packages-select mlmap_bridge --event-handlers console_direct+ \
 && colcon test-result --verbose
# The UDP-only Fast DDS profile (see compose.yaml), at the same path as in the onboard image.
COPY config/dds/udp_only.xml /opt/mlmap/config/dds/udp_only.xml
COPY docker/ground_entrypoint.sh /ground_entrypoint.sh
ENTRYPOINT ["/ground_entrypoint.sh"]
CMD ["ros2", "launch", "mlmap_bridge", "bridge.launch.py", "rviz:=false"]
