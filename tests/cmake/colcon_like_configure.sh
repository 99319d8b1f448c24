#!/usr/bin/env bash
# Configures mlmap as a plain `colcon build` of a ROS 2 Jazzy workspace does (no options; CMake
# finds ROS's Fast DDS 2.14, emulated here by a package config that says 2.14.0, first on the
# prefix path): the configuration must succeed, say why the DDS component is off, and keep the
# mapping core. Then with BUILD_TESTING=OFF (colcon's --cmake-args convention) the tests are off.
# Usage: colcon_like_configure.sh SOURCE_DIR
set -euo pipefail
source_dir=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

fake="$work/fake_jazzy/lib/cmake/fastrtps"
mkdir -p "$fake"
echo 'set(fastrtps_FOUND TRUE)' >"$fake/fastrtps-config.cmake"
cat >"$fake/fastrtps-config-version.cmake" <<'CMAKE'
set(PACKAGE_VERSION 2.14.0)
set(PACKAGE_VERSION_COMPATIBLE TRUE)
CMAKE

fail() { echo "FAIL: $*" >&2; exit 1; }

if ! cmake -S "$source_dir" -B "$work/build" -G Ninja -DMLMAP_BUILD_APPS=OFF \
    -DCMAKE_PREFIX_PATH="$work/fake_jazzy" >"$work/configure.log" 2>&1; then
  cat "$work/configure.log" >&2
  fail "the configuration failed where it should turn the DDS component off"
fi
grep -q "the DDS component (mlmap_node, the IDL types, the bag reader) is off: Fast DDS 2.14.0" \
  "$work/configure.log" || { cat "$work/configure.log" >&2; fail "no message saying why DDS is off"; }
grep -q '^build mlmap_node' "$work/build/build.ninja" && fail "mlmap_node is still a target"
grep -q 'libmlmap_pipeline.a' "$work/build/build.ninja" || fail "the mapping core is not built"
grep -q '^MLMAP_BUILD_TESTS:BOOL=ON' "$work/build/CMakeCache.txt" || fail "tests not on by default"

cmake -S "$source_dir" -B "$work/build_no_tests" -G Ninja -DMLMAP_BUILD_APPS=OFF -DBUILD_TESTING=OFF \
  -DCMAKE_PREFIX_PATH="$work/fake_jazzy" >"$work/configure2.log" 2>&1 ||
  { cat "$work/configure2.log" >&2; fail "configuration with BUILD_TESTING=OFF failed"; }
grep -q '^MLMAP_BUILD_TESTS:BOOL=OFF' "$work/build_no_tests/CMakeCache.txt" ||
  fail "BUILD_TESTING=OFF left the tests on"
echo "OK: a colcon-like configuration turns DDS off with its reason and keeps the core"
