#!/usr/bin/env bash
# Container integration test: builds the onboard and ground-station images, starts the simulated
# depth camera, mlmap_node and the ROS 2 bridge (docker/compose.yaml), then runs the checker,
# which waits until every layer reached ROS 2 with the right type and plausible content and
# `ros2 topic list` shows every topic. Prints the checker's report and exits with its verdict
# (0: passed). Logs of the other services go to docker/integration_logs/.
#   bash docker/run_integration_test.sh
# Needs Docker with the compose plugin. No Docker engine runs on the project's CI machines: there
# the checker's logic runs as unit tests (tools/ros2/mlmap_bridge/test) instead.
set -euo pipefail
cd "$(dirname "$0")/.."
compose=(docker compose -f docker/compose.yaml -p mlmap_integration)
logs=docker/integration_logs

rmem_max=$(sysctl -n net.core.rmem_max 2>/dev/null || echo 0)
if [ "$rmem_max" -lt 4194304 ]; then
  echo "note: net.core.rmem_max is $rmem_max; large best-effort samples may be lost over UDP" \
       "(sudo sysctl -w net.core.rmem_max=4194304 raises it)"
fi

# shellcheck disable=SC2317  # (run by the EXIT trap)
finish() {
  mkdir -p "$logs"
  for service in node publisher bridge; do
    "${compose[@]}" logs --no-color "$service" > "$logs/$service.log" 2>&1 || true
  done
  "${compose[@]}" --profile test down --remove-orphans > /dev/null 2>&1 || true
}
trap finish EXIT

"${compose[@]}" --profile test build
"${compose[@]}" up -d node publisher bridge
verdict=0
"${compose[@]}" run --rm checker || verdict=$?
if [ "$verdict" -eq 0 ]; then
  echo "integration test PASSED"
else
  echo "integration test FAILED (checker exit code $verdict); logs in $logs/"
fi
exit "$verdict"
