#!/usr/bin/env bash
# Lints the project's Python (the ROS 2 ground-station files, which cannot run on these machines:
# no ROS 2, no Docker engine; the benchmarks; the docs check) with flake8 (99 columns, as
# ament_flake8) and pydocstyle (pep257, as ament_pep257), and shell scripts with bash -n and
# with ShellCheck. Dockerfiles, compose.yaml, the manifests and the RViz config are checked by
# test_ground_station_files.py and the bridge's tests.
set -euo pipefail
cd "$(dirname "$0")/../.."
python_dirs=(tools/ros2 tests/ros2 tests/benchmarks tests/docs)
shell_scripts=(docker/run_integration_test.sh docker/ground_entrypoint.sh docker/runtime_packages.sh
               tests/ros2/lint.sh)
# The project's other scripts: warnings and errors (quoting, word splitting), not style.
other_scripts=(tools/*.sh tests/dds/*.sh tests/interop/*.sh tests/integration/*.sh tests/faults/*.sh
               tests/security/*.sh tests/benchmarks/*.sh tests/support/*.sh .ci/run)
# (build, install and log: what a colcon build inside tools/ros2 would leave)
/usr/bin/python3 -m flake8 --max-line-length 99 --extend-exclude build,install,log \
  "${python_dirs[@]}"
pydocstyle --convention=pep257 --match-dir='^(?!(build|install|log)$)[^.].*' "${python_dirs[@]}"
for script in "${shell_scripts[@]}"; do
  bash -n "$script"
done
shellcheck "${shell_scripts[@]}"
shellcheck -S warning "${other_scripts[@]}"
echo "lint: flake8, pydocstyle, bash -n and shellcheck found nothing"
