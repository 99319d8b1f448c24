#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds everything with warnings as errors and
# runs every test through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh
cmake -S . -B build-test -DCMAKE_BUILD_TYPE=Release -DMLMAP_WERROR=ON -DMLMAP_BUILD_TESTS=ON >/dev/null
cmake --build build-test -j2
ctest --test-dir build-test --output-on-failure -j2 --timeout 900

# The threaded parts again under ThreadSanitizer: planner threads querying while the mapping,
# planning and ESDF worker threads run (a data race fails the run).
echo "== ThreadSanitizer: concurrency tests"
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMLMAP_WERROR=ON -DMLMAP_BUILD_TESTS=ON \
  -DMLMAP_SANITIZE=thread -DMLMAP_BUILD_DDS=OFF >/dev/null
cmake --build build-tsan -j2 --target mlmap_concurrency_tests
TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" build-tsan/tests/mlmap_concurrency_tests
