#!/usr/bin/env bash
# Fuzzes every parser of outside data (tests/fuzz, docs/fuzzing.md) with libFuzzer for a bounded
# time, each target on a scratch copy of its seed corpus and regression inputs (nothing is written
# into tests/). Prints executions, exec/s and coverage per target and a final table; exits
# non-zero when a target crashed, and says where the reproducer is and how to keep it.
#
#   bash tools/fuzz.sh --build build-asan                     # 15 s per target, 2 at a time
#   bash tools/fuzz.sh --build build-asan --seconds 600 --jobs 2 --out fuzz_out   # the long run
#
# DIR must be a clang tree configured with -DMLMAP_FUZZ=ON (and, as CI does, with
# -DMLMAP_SANITIZE=address,undefined); the fuzz targets are built first (`--target mlmap_fuzz`).
set -euo pipefail

usage() {
  cat <<'EOF'
usage: tools/fuzz.sh --build DIR [--seconds N] [--jobs J] [--targets "a b"] [--out DIR] [--no-build]
  --build DIR    clang build tree configured with -DMLMAP_FUZZ=ON (required)
  --seconds N    fuzzing time per target in seconds (default 15; 1..86400)
  --jobs J       targets fuzzed at the same time (default 2)
  --targets L    only these targets, e.g. "fuzz_pcd fuzz_ply" (default: every fuzz_* of DIR)
  --out DIR      where the scratch corpora, logs and crash files go (default: a new temp folder)
  --no-build     do not run `cmake --build DIR --target mlmap_fuzz` first
EOF
}

build=""
seconds=15
jobs=2
targets=""
out=""
do_build=1
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="${2:?--build needs a directory}"; shift 2 ;;
    --seconds) seconds="${2:?--seconds needs a number}"; shift 2 ;;
    --jobs) jobs="${2:?--jobs needs a number}"; shift 2 ;;
    --targets) targets="${2:?--targets needs a list}"; shift 2 ;;
    --out) out="${2:?--out needs a directory}"; shift 2 ;;
    --no-build) do_build=0; shift ;;
    -h | --help) usage; exit 0 ;;
    *) echo "fuzz.sh: unknown argument '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
[ -n "$build" ] || { echo "fuzz.sh: --build DIR is required" >&2; usage >&2; exit 2; }
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 1 ] || [ "$seconds" -gt 86400 ]; then
  echo "fuzz.sh: --seconds must be an integer in 1..86400, got '$seconds'" >&2
  exit 2
fi
if ! [[ "$jobs" =~ ^[0-9]+$ ]] || [ "$jobs" -lt 1 ]; then
  echo "fuzz.sh: --jobs must be a positive integer, got '$jobs'" >&2
  exit 2
fi
grep -q '^MLMAP_FUZZ:BOOL=ON' "$build/CMakeCache.txt" 2>/dev/null || {
  echo "fuzz.sh: $build is not a build tree configured with -DMLMAP_FUZZ=ON; make one with" >&2
  echo "  CC=clang CXX=clang++ cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo \\" >&2
  echo "    -DMLMAP_BUILD_TESTS=ON -DMLMAP_SANITIZE=address,undefined -DMLMAP_FUZZ=ON" >&2
  exit 2
}

repo="$(cd "$(dirname "$0")/.." && pwd)"
fuzz_src="$repo/tests/fuzz"
if [ "$do_build" = 1 ]; then
  echo "building the fuzz targets in $build ..."
  cmake --build "$build" --target mlmap_fuzz -j "$jobs" >/dev/null
fi
bin_dir="$build/tests/fuzz"
if [ -z "$targets" ]; then
  targets="$(cd "$bin_dir" && find . -maxdepth 1 -type f -name 'fuzz_*' -perm -u+x | sed 's|^\./||' | sort | tr '\n' ' ')"
fi
[ -n "$targets" ] || { echo "fuzz.sh: no fuzz_* targets in $bin_dir" >&2; exit 2; }
for t in $targets; do
  [ -x "$bin_dir/$t" ] || { echo "fuzz.sh: no target $bin_dir/$t" >&2; exit 2; }
done
if [ -z "$out" ]; then
  out="$(mktemp -d "${TMPDIR:-/tmp}/mlmap_fuzz.XXXXXX")"
fi
mkdir -p "$out"
out="$(cd "$out" && pwd)"

# Sanitizers stop at the first report; leaks count as crashes. Reports name functions and lines
# with llvm-14's symbolizer (Debian installs it without the unversioned name on the PATH).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
if [ -z "${ASAN_SYMBOLIZER_PATH:-}" ] && [ -x /usr/lib/llvm-14/bin/llvm-symbolizer ]; then
  export ASAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
fi

# Fuzzes one target; its log, scratch corpus and any crash file go to $out/<target>/.
fuzz_one() {
  local t="$1" dir="$out/$1"
  rm -rf "$dir"
  mkdir -p "$dir/corpus" "$dir/artifacts"
  cp "$fuzz_src/corpus/$t/"* "$dir/corpus/" 2>/dev/null || true
  if [ -d "$fuzz_src/regressions/$t" ]; then cp "$fuzz_src/regressions/$t/"* "$dir/corpus/" 2>/dev/null || true; fi
  local dict=()
  [ -f "$fuzz_src/dict/$t.dict" ] && dict=(-dict="$fuzz_src/dict/$t.dict")
  local rc=0
  # -timeout: one input may take at most 10 s; -rss_limit_mb: and at most 2 GB (malloc too).
  "$bin_dir/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$dir/artifacts/" "${dict[@]}" "$dir/corpus" >"$dir/log" 2>&1 || rc=$?
  echo "$rc" >"$dir/rc"
}

# Executions, exec/s, coverage (edges), features, corpus size, peak RSS and the verdict of one target.
summarize() {
  local t="$1" dir="$out/$1"
  local rc execs speed cov ft corp rss verdict crash
  rc="$(cat "$dir/rc")"
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log" | tail -1)"
  speed="$(sed -n 's/^stat::average_exec_per_sec: *//p' "$dir/log" | tail -1)"
  rss="$(sed -n 's/^stat::peak_rss_mb: *//p' "$dir/log" | tail -1)"
  # The last status line, e.g. "#52311 REDUCE cov: 812 ft: 2570 corp: 231/18Kb ...".
  cov="$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' "$dir/log" | tail -1)"
  ft="$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' "$dir/log" | tail -1)"
  corp="$(sed -n 's/.* corp: \([0-9]*\).*/\1/p' "$dir/log" | tail -1)"
  crash="$(find "$dir/artifacts" -type f | head -1)"
  if [ "$rc" = 0 ] && [ -z "$crash" ]; then verdict="ok"; else verdict="CRASH"; fi
  printf '%-28s %12s %9s %7s %7s %7s %8s  %s\n' "$t" "${execs:-?}" "${speed:-?}" "${cov:-?}" \
    "${ft:-?}" "${corp:-?}" "${rss:-?}" "$verdict"
}

n_targets=$(echo "$targets" | wc -w)
echo "fuzzing $n_targets targets for $seconds s each, $jobs at a time; scratch and logs in $out"
start=$(date +%s)
running=0
for t in $targets; do
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  echo "  [$(($(date +%s) - start)) s] start $t"
  fuzz_one "$t" &
  running=$((running + 1))
done
wait || true
echo "  [$(($(date +%s) - start)) s] done"

echo
printf '%-28s %12s %9s %7s %7s %7s %8s  %s\n' target executions exec/s cov ft corpus rss_mb verdict
failed=0
for t in $targets; do
  summarize "$t"
  if [ "$(cat "$out/$t/rc")" != 0 ] || [ -n "$(find "$out/$t/artifacts" -type f | head -1)" ]; then
    failed=1
  fi
done
echo "(cov: edges covered in the instrumented parsers; ft: libFuzzer features; ${seconds} s per target)"

if [ "$failed" = 1 ]; then
  echo
  for t in $targets; do
    crash="$(find "$out/$t/artifacts" -type f | head -1)"
    if [ "$(cat "$out/$t/rc")" != 0 ] || [ -n "$crash" ]; then
      echo "$t FAILED: the report is in $out/$t/log"
      grep -m1 -E 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|property violated|terminate called' "$out/$t/log" || true
      if [ -n "$crash" ]; then
        echo "  reproducer: $crash"
        echo "  reproduce:  $bin_dir/$t $crash"
        echo "  keep it:    mkdir -p tests/fuzz/regressions/$t && cp $crash tests/fuzz/regressions/$t/<what-it-does>"
        echo "              then fix the bug; ctest -R ${t}_corpus runs it in every build from then on"
      fi
    fi
  done
  exit 1
fi
echo "no crash in $n_targets targets ($(($(date +%s) - start)) s)"
