#!/usr/bin/env bash
# Entrypoint of the ground-station image: ROS 2 Jazzy and the mlmap workspace in the
# environment, then the command (the bridge by default, mlmap_check for the integration test).
set -e
# shellcheck source=/dev/null
source /opt/ros/jazzy/setup.bash --  # "--": the setup scripts must not see the command
# shellcheck source=/dev/null
source /opt/mlmap_ws/install/setup.bash --
exec "$@"
