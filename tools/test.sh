#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds everything with warnings as errors and
# runs every test through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh
cmake -S . -B build-test -DCMAKE_BUILD_TYPE=Release -DMLMAP_WERROR=ON -DMLMAP_BUILD_TESTS=ON >/dev/null
cmake --build build-test -j2
ctest --test-dir build-test --output-on-failure -j2 --timeout 900
