#!/usr/bin/env bash
# The main job: installs what is missing, builds (Release) and runs the demo on the built-in
# simulated room. Pictures, accuracy, timings and memory land in demo_output/.
# Extra arguments go to mlmap_demo (see `build/mlmap_demo --help`), e.g.
#   bash tools/demo.sh --frames ../shared/data/realsense_tabletop
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMLMAP_BUILD_TESTS=OFF >/dev/null
cmake --build build -j2 --target mlmap_demo
./build/mlmap_demo --out demo_output "$@"
