#!/usr/bin/env bash
# Static analysis of mlmap's own code (src/, include/, tests/) with the checked-in configuration:
# the layout (.clang-format, every C++ file git knows), cppcheck
# (tools/analysis/cppcheck-suppressions.txt) and clang-tidy (.clang-tidy).
#   bash tools/lint.sh [--build DIR] [--cppcheck-only | --clang-tidy-only] [--deep] [FILE...]
# DIR holds compile_commands.json (default: build-asan, the test command's tree; any configured
# tree works). FILEs limit clang-tidy to those sources (default: src/). --deep adds the clang static
# analyzer (clang-analyzer-*, about three times the time). Exits non-zero on any finding.
set -euo pipefail
cd "$(dirname "$0")/.."
build="build-asan"
run_cppcheck=1
run_tidy=1
tidy_checks=()
files=()
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --cppcheck-only) run_tidy=0; shift ;;
    --clang-tidy-only) run_cppcheck=0; shift ;;
    --deep) tidy_checks=(-checks='clang-analyzer-*'); shift ;;
    -h | --help) sed -n '2,9p' "$0"; exit 0 ;;
    -*) echo "lint.sh: unknown option $1" >&2; exit 2 ;;
    *) files+=("$1"); shift ;;
  esac
done
jobs=$(nproc)
status=0

# The layout first: a few seconds. `clang-format -i FILE` fixes what it reports.
echo "== clang-format $(clang-format --version | sed -n 's/.*version \([0-9.]*\).*/\1/p'): C++ layout"
mapfile -t cxx < <(git ls-files '*.cpp' '*.h')
clang-format --dry-run --Werror "${cxx[@]}" || {
  echo "   clang-format: the files above differ from .clang-format's layout (clang-format -i FILE)"
  status=1
}

if [ "$run_cppcheck" = 1 ]; then
  echo "== cppcheck $(cppcheck --version | cut -d' ' -f2): src/ include/ tests/"
  start=$SECONDS
  cppcheck --std=c++17 --language=c++ --library=googletest -I include \
    --enable=warning,performance,portability,style --inline-suppr \
    --suppressions-list=tools/analysis/cppcheck-suppressions.txt \
    --error-exitcode=1 --quiet -j "$jobs" src include tests || status=1
  echo "   cppcheck: $((SECONDS - start)) s"
fi

if [ "$run_tidy" = 1 ]; then
  if [ ! -f "$build/compile_commands.json" ]; then
    echo "lint.sh: $build/compile_commands.json missing: configure and build $build first" >&2
    exit 2
  fi
  if [ ${#files[@]} -eq 0 ]; then
    # The library and program sources (tests are cppcheck's; generated IDL code is not ours).
    mapfile -t files < <(git ls-files 'src/*.cpp')
  fi
  mapfile -t files < <(realpath -- "${files[@]}")  # compile_commands.json has absolute paths
  echo "== clang-tidy $(clang-tidy --version | sed -n 's/.*version \([0-9.]*\).*/\1/p'): ${#files[@]} files"
  start=$SECONDS
  # run-clang-tidy runs one clang-tidy per file in parallel; -quiet keeps only findings.
  run-clang-tidy -quiet -j "$jobs" -p "$build" "${tidy_checks[@]}" "${files[@]}" >"$build/clang-tidy.log" 2>&1 ||
    status=1
  grep -E '(warning|error):' "$build/clang-tidy.log" | sort -u || true
  echo "   clang-tidy: $((SECONDS - start)) s (full log: $build/clang-tidy.log)"
fi
exit "$status"
