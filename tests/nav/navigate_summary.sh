#!/usr/bin/env bash
# The navigation demo (tools/demo.sh --navigate runs mlmap_navigate so), short: the first two
# benchmark worlds (forests); checks nav_output's pictures and that summary.json has exactly the
# keys of issue 45, with totals that agree with the worlds.
#   navigate_summary.sh <mlmap_navigate> <out dir>
set -euo pipefail
navigate=$1 out=$2
rm -rf "$out"
"$navigate" --worlds 2 --out "$out"
python3 - "$out" <<'PY'
import json, os, sys
out = sys.argv[1]
s = json.load(open(os.path.join(out, "summary.json")))
def fail(why):
    print("FAIL:", why); sys.exit(1)
if list(s) != ["worlds", "totals"]: fail("top-level keys %s" % list(s))
keys = ["name", "reached", "collisions", "min_clearance_m", "path_length_m", "shortest_path_m",
        "time_s", "replans", "map_to_plan_ms_p99"]
if len(s["worlds"]) != 2: fail("%d worlds, not 2" % len(s["worlds"]))
for w in s["worlds"]:
    if list(w) != keys: fail("world keys %s" % list(w))
    png = os.path.join(out, w["name"] + ".png")
    if not os.path.getsize(png) > 10000: fail(png + " missing or empty")
    if w["shortest_path_m"] <= 0 or w["path_length_m"] <= 0 or w["time_s"] <= 0: fail(w["name"] + ": no flight")
    if w["map_to_plan_ms_p99"] <= 0: fail(w["name"] + ": no latency")
if list(s["totals"]) != ["reached_fraction", "collisions"]: fail("totals keys %s" % list(s["totals"]))
reached = sum(1 for w in s["worlds"] if w["reached"]) / len(s["worlds"])
if abs(s["totals"]["reached_fraction"] - reached) > 1e-12: fail("reached_fraction")
if s["totals"]["collisions"] != sum(w["collisions"] for w in s["worlds"]): fail("collisions total")
print("navigate summary OK:", [(w["name"], w["reached"], w["collisions"]) for w in s["worlds"]])
PY
