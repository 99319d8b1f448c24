#!/usr/bin/env bash
# Hostile inputs to the programs, across processes (docs/soak-and-faults.md, "What we tried"):
#   hostile_inputs.sh <bin dir> <out dir> <domain id>
# 1. mlmap_map_tool never writes over its input, nor over an existing map without --overwrite;
#    --bench touches no existing file; an absurd --band is refused at once (it used to loop past
#    2^31); /dev/zero and a directory as the map are refused with their path.
# 2. mlmap_node: a load_path naming a directory is refused with its path; an existing map at
#    save_path that was not loaded stops it at start; SIGTERM while it loads a large map ends it
#    within 2 s (it used to take SIGKILL).
set -uo pipefail
bin=$1 out=$2
export ROS_DOMAIN_ID=$3
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
rm -rf "$out" && mkdir -p "$out"
node=''
trap '[ -n "$node" ] && kill -9 $node 2>/dev/null' EXIT
fail() { echo "FAIL: $*"; for f in "$out"/*.log; do echo "== $f"; cat "$f"; done; exit 1; }
# expect_refusal STATUS TEXT CMD...: CMD exits with STATUS within 10 s and prints TEXT.
expect_refusal() {
  local status=$1 text=$2 rc; shift 2
  timeout 10 "$@" > "$out/refusal.log" 2>&1; rc=$?
  [ "$rc" -eq "$status" ] || fail "$*: exit status $rc, expected $status"
  grep -qF -- "$text" "$out/refusal.log" || fail "$*: no '$text' in its output"
}

# A map to work on: the simulator's flight, 20 frames (no shared data needed).
"$bin/mlmap_replay" --max-frames 20 --out "$out/replay" --save-map "$out/map.mlmap" > "$out/replay.log" 2>&1 \
  || fail "mlmap_replay could not make a map"
sum() { md5sum "$1" | cut -d' ' -f1; }
map_sum=$(sum "$out/map.mlmap")

echo "== 1. mlmap_map_tool"
expect_refusal 2 "is an input of this run" "$bin/mlmap_map_tool" "$out/map.mlmap" --ply "$out/map.mlmap"
expect_refusal 2 "is an input of this run" "$bin/mlmap_map_tool" "$out/map.mlmap" --pcd "$out/../$(basename "$out")/map.mlmap"
cp "$out/map.mlmap" "$out/other.mlmap"
expect_refusal 2 "is an existing mlmap map: give another path, or --overwrite" \
  "$bin/mlmap_map_tool" "$out/map.mlmap" --ply "$out/other.mlmap"
"$bin/mlmap_map_tool" "$out/map.mlmap" --ply "$out/other.mlmap" --overwrite > "$out/overwrite.log" 2>&1 \
  || fail "--overwrite did not allow replacing another map"
echo "precious" > "$out/map.mlmap.bench"
"$bin/mlmap_map_tool" "$out/map.mlmap" --bench 2 > "$out/bench.log" 2>&1 || fail "--bench failed"
[ "$(cat "$out/map.mlmap.bench")" = precious ] || fail "--bench touched an existing file"
compgen -G "$out/map.mlmap.bench-*" > /dev/null && fail "--bench left its file behind"
expect_refusal 2 "--band: heights must be finite" "$bin/mlmap_map_tool" "$out/map.mlmap" --grid "$out/g" --band 1e8 2e8
expect_refusal 1 "/dev/zero: is not a regular file" "$bin/mlmap_map_tool" /dev/zero --info
expect_refusal 105 "directory" "$bin/mlmap_map_tool" "$out" --info   # CLI11 checks the argument
[ "$(sum "$out/map.mlmap")" = "$map_sum" ] || fail "the input map changed"

echo "== 2. mlmap_node"
printf 'map_file: {load_path: %s}\n' "$out" > "$out/dir.yaml"
expect_refusal 1 "$out: is a directory, not a map file" "$bin/mlmap_node" -c "$out/dir.yaml" --duration 5
printf 'map_file: {save_path: %s}\n' "$out/map.mlmap" > "$out/replace.yaml"
expect_refusal 1 "already exists and is not the map this node loaded" "$bin/mlmap_node" -c "$out/replace.yaml" --duration 5
[ "$(sum "$out/map.mlmap")" = "$map_sum" ] || fail "the node replaced an existing map"

# A map with a large window (54 million voxels at 2 cm) loads for seconds: the ESDF of the whole
# window is computed before the node runs.
big='local_map: {resolution_m: 0.02, size_cells: [600, 600, 150]}'
printf '%s\n' "$big" > "$out/big_engine.yaml"
"$bin/mlmap_replay" --max-frames 2 --config "$out/big_engine.yaml" --out "$out/big" --save-map "$out/big.mlmap" \
  > "$out/big_replay.log" 2>&1 || fail "mlmap_replay could not make the large map"
printf '%s\nmap_file: {load_path: %s}\n' "$big" "$out/big.mlmap" > "$out/big.yaml"
"$bin/mlmap_node" -c "$out/big.yaml" --report-every 0 > "$out/big_node.log" 2>&1 &
node=$!
for _ in $(seq 100); do grep -q "memory of the configured layers" "$out/big_node.log" && break; sleep 0.05; done
sleep 0.2
start=$(date +%s.%N)
kill -TERM "$node"
wait "$node"; rc=$?
node=''
took=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }')
awk -v t="$took" 'BEGIN { exit !(t <= 2.0) }' || fail "SIGTERM during the load: the node took $took s to end"
[ "$rc" -eq 143 ] || fail "SIGTERM during the load: exit status $rc, expected 143 (terminated by SIGTERM)"
grep -q "loaded map" "$out/big_node.log" && fail "the load was over before SIGTERM: the map is not large enough to test this"
grep -q "stop signal during start-up" "$out/big_node.log" || fail "no word about the stop during start-up"
echo "SIGTERM during the load ended the node in $took s"
echo "PASS"
