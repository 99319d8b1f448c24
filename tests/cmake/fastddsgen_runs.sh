#!/usr/bin/env bash
# The IDL generation step of the build (cmake/RunFastddsgen.cmake), as two builds on one machine
# run it: two runs at the same time over every IDL file of idl/ must both succeed and generate
# the same files (fastddsgen's default temporary directory, /tmp, is shared by every run: two
# runs there truncated each other's preprocessed files); a run over a broken IDL file must fail
# with fastddsgen's message and leave nothing in the output folder.
# Usage: fastddsgen_runs.sh SOURCE_DIR
set -uo pipefail
source_dir=$1
script=$source_dir/cmake/RunFastddsgen.cmake
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v fastddsgen >/dev/null || fail "fastddsgen is missing (tools/install_deps.sh installs it)"

files=$(find "$source_dir/idl" -path '*/msg/*_.idl' -o -path '*/srv/*_.idl' | sort | paste -sd'|')
[ -n "$files" ] || fail "no IDL files under $source_dir/idl"
run() {  # run NAME IDL_ROOT FILES
  cmake "-DFASTDDSGEN=$(command -v fastddsgen)" "-DIDL_ROOT=$2" "-DIDL_FILES=$3" \
    "-DGEN_DIR=$work/$1/gen" "-DWORK_DIR=$work/$1/work" -P "$script" > "$work/$1.log" 2>&1
}
run a "$source_dir/idl" "$files" & a=$!
run b "$source_dir/idl" "$files" & b=$!
wait $a; a_rc=$?
wait $b; b_rc=$?
[ $a_rc = 0 ] || { cat "$work/a.log"; fail "the first of two runs at once failed"; }
[ $b_rc = 0 ] || { cat "$work/b.log"; fail "the second of two runs at once failed"; }
count=$(find "$work/a/gen" -type f | wc -l)
[ "$count" -eq $(( $(echo "$files" | tr '|' '\n' | wc -l) * 4 )) ] || fail "expected 4 files per IDL file, got $count"
# fastddsgen writes Java object ids into comments ("// m_x_ ...TypeCode@1b6e1eff"): those may differ.
diff -r -I '^ *// m_.* com\.eprosima\..*@[0-9a-f]*$' "$work/a/gen" "$work/b/gen" > "$work/diff.txt" ||
  { head -20 "$work/diff.txt"; fail "the two runs generated different code"; }
grep -rL "class\|struct" "$work/a/gen" --include='*.h' | head -1 | grep -q . && fail "a header without any type"

mkdir -p "$work/bad/pkg/msg"
printf 'module pkg { module msg { struct Broken_ { long a;\n' > "$work/bad/pkg/msg/Broken_.idl"
run broken "$work/bad" "$work/bad/pkg/msg/Broken_.idl" && fail "a broken IDL file did not fail the step"
grep -q "fastddsgen failed" "$work/broken.log" || { cat "$work/broken.log"; fail "no clear message"; }
[ ! -e "$work/broken/gen" ] || fail "a failed run left generated files behind"
echo "PASS: two runs at once generated the same $count files; a broken IDL file fails the step"
