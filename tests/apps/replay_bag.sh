#!/usr/bin/env bash
# mlmap_replay --bag on the test bags that other writers made (tests/bag/fixtures):
#   replay_bag.sh <mlmap_replay> <bags dir> <out dir>
# 1. The same clouds in an MCAP file (zstd chunks), a bag folder and a sqlite3 .db3 give the
#    same map, voxel for voxel, with the reader thread and without it.
# 2. A depth Image with its CameraInfo and Odometry (lz4 chunks) is mapped.
# 3. Poses from /tf: without --world-frame the error lists the topics and names the option;
#    with it, every frame is mapped.
# 4. --save-map never replaces an existing map without --overwrite.
set -uo pipefail
replay=$1 bags=$2 out=$3
rm -rf "$out" && mkdir -p "$out"
fail() { echo "FAIL: $*"; cat "$out"/*.log 2>/dev/null | tail -40; exit 1; }
run() {  # run NAME ARGS...: a replay into $out/NAME; fails unless it exits 0
  local name=$1; shift
  "$replay" --out "$out/$name" "$@" > "$out/$name.log" 2>&1 || fail "$name: exit status $?"
}
mapped() { sed -n 's/^ *frames mapped *\([0-9]*\).*/\1/p' "$out/$1.log"; }

run mcap --bag "$bags/clouds_zstd.mcap"
run folder --bag "$bags/clouds_folder" --reader-threads 0
run db3 --bag "$bags/clouds.db3"
[ "$(mapped mcap)" = 4 ] || fail "clouds_zstd.mcap: $(mapped mcap) frames mapped, expected 4"
n=$(grep -vc '^#' "$out/mcap/occupied_voxels.txt")
[ "$n" -gt 50 ] || fail "clouds_zstd.mcap: only $n occupied voxels"
cmp -s "$out/mcap/occupied_voxels.txt" "$out/folder/occupied_voxels.txt" || fail "the bag folder maps differently"
cmp -s "$out/mcap/occupied_voxels.txt" "$out/db3/occupied_voxels.txt" || fail "the .db3 bag maps differently"

run depth --bag "$bags/depth_lz4.mcap"
[ "$(mapped depth)" = 3 ] || fail "depth_lz4.mcap: $(mapped depth) frames mapped, expected 3"

"$replay" --out "$out/tf_none" --bag "$bags/tf_chain.mcap" > "$out/tf_none.log" 2>&1 && fail "tf_chain.mcap mapped without --world-frame"
grep -q -- "--world-frame" "$out/tf_none.log" || fail "tf_chain.mcap: the error does not name --world-frame"
grep -q "/tf (tf2_msgs/msg/TFMessage" "$out/tf_none.log" || fail "tf_chain.mcap: the error does not list the topics"
run tf --bag "$bags/tf_chain.mcap" --world-frame world
[ "$(mapped tf)" -gt 0 ] || fail "tf_chain.mcap: nothing mapped with --world-frame world"

run first --bag "$bags/clouds.db3" --save-map "$out/map.mlmap"
sum=$(md5sum < "$out/map.mlmap")
"$replay" --out "$out/again" --bag "$bags/depth_lz4.mcap" --save-map "$out/map.mlmap" > "$out/again.log" 2>&1 \
  && fail "--save-map replaced an existing map without --overwrite"
grep -q "is an existing mlmap map" "$out/again.log" || fail "no clear refusal to replace the map"
[ "$(md5sum < "$out/map.mlmap")" = "$sum" ] || fail "the existing map changed"
run again --bag "$bags/depth_lz4.mcap" --save-map "$out/map.mlmap" --overwrite
echo PASS
