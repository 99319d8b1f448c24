#!/usr/bin/env bash
# The fleet demo (tools/demo.sh --fleet 3 runs mlmap_fleet_demo so), short: three vehicles through
# the building, 30 frames each; checks fleet_output's pictures and summary.json: the issue's keys,
# each vehicle's frames all mapped and bytes sent, the merged map's accuracy (noise-free: F1 >=
# 0.99) and its agreement with one engine fed every vehicle's frames (IoU >= 0.97).
#   fleet_demo_summary.sh <mlmap_fleet_demo> <source dir> <out dir>
set -euo pipefail
demo=$1 src=$2 out=$3
rm -rf "$out"
"$demo" --scenario "$src/config/worlds/fleet/uav1.yaml" --scenario "$src/config/worlds/fleet/uav2.yaml" \
  --scenario "$src/config/worlds/fleet/uav3.yaml" --max-frames 30 --out "$out"
for f in fleet_top.png uav1_top.png uav2_top.png uav3_top.png summary.json; do
  test -s "$out/$f" || { echo "FAIL: $out/$f missing"; exit 1; }
done
python3 - "$out/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
def fail(why):
    print("FAIL:", why); sys.exit(1)
for key in ("vehicles", "merged", "seconds"):
    if key not in s: fail("summary.json lacks " + key)
if [v.get("name") for v in s["vehicles"]] != ["uav1", "uav2", "uav3"]: fail("vehicle names")
for v in s["vehicles"]:
    for key in ("name", "frames_mapped", "bytes_sent", "bytes_per_s"):
        if key not in v: fail(v.get("name", "?") + " lacks " + key)
    if v["frames_mapped"] != 30: fail(v["name"] + ": %d frames mapped of 30" % v["frames_mapped"])
    if v["bytes_sent"] <= 0: fail(v["name"] + " sent nothing")
    if abs(v["bytes_per_s"] * v["flight_s"] - v["bytes_sent"]) > 1e-6 * v["bytes_sent"]:
        fail(v["name"] + ": bytes_per_s is not bytes_sent over its flight")
m = s["merged"]
for key in ("occupied_voxels", "f1", "precision", "recall", "iou_vs_single_engine"):
    if key not in m: fail("merged lacks " + key)
if m["occupied_voxels"] <= 0: fail("nothing merged")
for key in ("f1", "precision", "recall", "iou_vs_single_engine"):
    if not 0.0 <= m[key] <= 1.0: fail("merged %s = %s" % (key, m[key]))
if m["f1"] < 0.99: fail("merged F1 %.4f < 0.99" % m["f1"])
if m["iou_vs_single_engine"] < 0.97: fail("merged IoU vs one engine %.4f < 0.97" % m["iou_vs_single_engine"])
if abs(s["seconds"] - max(v["flight_s"] for v in s["vehicles"])) > 1e-9: fail("seconds")
print("fleet demo summary: %d merged voxels, F1 %.4f, IoU vs one engine %.4f, %s B/s" % (
    m["occupied_voxels"], m["f1"], m["iou_vs_single_engine"],
    " / ".join("%.0f" % v["bytes_per_s"] for v in s["vehicles"])))
PY
