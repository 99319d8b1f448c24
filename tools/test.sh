#!/usr/bin/env bash
# The whole test suite (CI runs exactly this). Installs what is missing, then:
#   1. builds everything with clang, AddressSanitizer + UndefinedBehaviorSanitizer and warnings as
#      errors (build-asan/), and runs every test through ctest: a memory error, undefined
#      behaviour or a leak at exit (LeakSanitizer) fails the test that caused it;
#   2. builds the threaded tests with gcc and ThreadSanitizer (build-tsan/) and runs them;
#   3. fuzzes every parser of outside data for a short, bounded time (tools/fuzz.sh);
#   4. static analysis of our code: cppcheck and clang-tidy (tools/lint.sh). It starts right after
#      the build, in the background at the lowest CPU priority (nice 19), so that it takes the CPU
#      the ctest run leaves idle (the DDS tests run one at a time and mostly wait on the wall
#      clock: ctest keeps the two cores about 55 % busy), and yields it to everything else; its
#      report is printed at the end;
#   5. the containerized integration test (tests/integration/containers_podman.sh): the onboard
#      and simulation images built with podman (reused while their files are unchanged) and run
#      as sensor, node and ground station in network namespaces of its own.
# Each part prints its duration, and a summary closes the run. Benchmarks and the demo use the
# Release build of tools/demo.sh (build/), never these instrumented ones.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh

summary=()
part_start=$SECONDS
endPart() {  # endPart NAME: records how long the part that just ended took
  summary+=("$(printf '%-44s %4d s' "$1" $((SECONDS - part_start)))")
  part_start=$SECONDS
}
printSummary() {
  echo "== tools/test.sh: time per part"
  printf '   %s\n' "${summary[@]}"
}
lint_pid=""
finish() {
  if [ -n "$lint_pid" ]; then kill -- "-$lint_pid" 2>/dev/null || true; fi  # a part failed first
  printSummary
}
trap finish EXIT

# Both trees use Ninja (the clang ASan build: 615 s against make's 692 s on a 2-core VM). A tree
# configured earlier with another generator is scratch: it is made again.
freshIfNotNinja() {
  if [ -f "$1/CMakeCache.txt" ] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$1/CMakeCache.txt"; then
    echo "   $1 was configured with another generator: removing it"
    rm -rf "$1"
  fi
}

echo "== 1. the whole suite under AddressSanitizer + UndefinedBehaviorSanitizer (clang)"
# -O2 and NDEBUG as the shipped build, so that the code paths checked are the optimised ones
# (Eigen's per-coefficient asserts would also triple the cost of the slow reference walks);
# line tables for readable reports.
freshIfNotNinja build-asan
CC=clang-14 CXX=clang++-14 cmake -G Ninja -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -gline-tables-only -DNDEBUG" -DMLMAP_WERROR=ON \
  -DMLMAP_BUILD_TESTS=ON -DMLMAP_BUILD_DDS=ON -DMLMAP_SANITIZE=address,undefined -DMLMAP_FUZZ=ON >/dev/null
cmake --build build-asan -j2
endPart "build, clang + ASan + UBSan"
lint_log=build-asan/lint.log
lint_start=$SECONDS
# Job control on for this one job: its own process group (lint_pid is its id), so that a failing
# part stops all of it; the EXIT trap is this shell's, not the job's. Not setsid: a new session
# gets a scheduler autogroup of its own, which shares the CPU equally with this one whatever its
# nice value (ctest took 643 s instead of 433 that way).
set -m
(trap - EXIT; exec nice -n 19 bash tools/lint.sh --build build-asan >"$lint_log" 2>&1) &
lint_pid=$!
set +m
echo "== 4. static analysis started in the background (nice 19; report at the end: $lint_log)"
# new_delete_type_mismatch=0: Fast DDS 2.9 deletes its StatisticsWriterImpl / StatisticsReaderImpl
# through a base pointer of another size, which aborts every DDS program (not our code).
export ASAN_OPTIONS="detect_leaks=1:check_initialization_order=1:strict_init_order=1:new_delete_type_mismatch=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$PWD/tools/analysis/lsan-suppressions.txt:print_suppressions=0"
export ASAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
ctest --test-dir build-asan --output-on-failure -j2 --timeout 900
endPart "ctest under ASan + UBSan + LSan"

# The threaded parts again under ThreadSanitizer: planner threads querying while the mapping,
# planning and ESDF worker threads run (a data race fails the run). gcc here, so that both
# compilers' warnings are errors in CI.
echo "== 2. ThreadSanitizer: concurrency tests (gcc)"
freshIfNotNinja build-tsan
cmake -G Ninja -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMLMAP_WERROR=ON -DMLMAP_BUILD_TESTS=ON \
  -DMLMAP_SANITIZE=thread -DMLMAP_BUILD_DDS=OFF >/dev/null
cmake --build build-tsan -j2 --target mlmap_concurrency_tests
TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" build-tsan/tests/mlmap_concurrency_tests
endPart "build + run, gcc + TSan"

echo "== 3. fuzzing: every target for a short, bounded time (docs/fuzzing.md)"
bash tools/fuzz.sh --build build-asan --no-build --seconds 15 --jobs 2
endPart "libFuzzer, 15 s per target"

# The onboard and simulation images built with podman (reused while the files they are built
# from are unchanged; a new machine builds them from scratch) and run in network namespaces.
echo "== 5. the containerized integration test (tests/integration/containers_podman.sh)"
bash tests/integration/containers_podman.sh
endPart "containers: images + sensor, node, ground"

echo "== 4. static analysis (cppcheck + clang-tidy), started after the build"
lint_status=0
wait "$lint_pid" || lint_status=$?
lint_pid=""
cat "$lint_log"
endPart "cppcheck + clang-tidy: the wait for them"
summary+=("$(printf '   (%-41s %4d s)' "cppcheck + clang-tidy, from start to end" $((SECONDS - lint_start)))")
exit "$lint_status"
