#!/usr/bin/env bash
# The planner over DDS, three processes on loopback as on a vehicle: mlmap_sensor_publisher
# --closed-loop (the simulated vehicle and its camera, the goal as RViz2 sends it) -> mlmap_node
# -> mlmap_planner_peer (the reference planner on the node's grid and ESDF) -> setpoints -> the
# vehicle. A small forest (the one the one-process closed-loop test flies) at 0.2 m.
#   navigation_loopback.sh <bin dir> <out dir> <domain id> [forest | person | person-blind]
# person: a sparser, longer forest (the one-process person test's) with a person crossing the
# route (--person-lead -1.5: where the vehicle, starting late over DDS, meets them), the planner
# reading the camera's clouds (--cloud-topic) as in the one-process flight; person-blind: the
# same without the clouds, to see what they change (not a test: the person walks into the
# vehicle). PERSON_LEAD=<m> sets another lead.
# Passes when the vehicle reaches the goal without touching anything (ground truth), and the
# planner planned on the node's maps (its map-to-plan line), rejected no message and saw the
# vehicle at the goal; with person also when the planner gave clouds' points to its planner.
set -uo pipefail
bin=$1 out=$2 mode=${4:-forest}
export ROS_DOMAIN_ID=$3
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what this test checks
rm -rf "$out" && mkdir -p "$out"
here=$(cd "$(dirname "$0")" && pwd)
cfg="$out/node.yaml"
# config/mlmap_node_nav.yaml at 0.2 m (the one-process flights' resolution), to keep it short.
sed -e 's/resolution_m: 0.1/resolution_m: 0.2/' -e 's/\[190, 190, 70\]/[95, 95, 35]/' \
  "$here/../../config/mlmap_node_nav.yaml" > "$cfg"
grep -q "resolution_m: 0.2" "$cfg" || { echo "FAIL: cannot derive the test configuration"; exit 1; }

person=(--world-seed 23 --forest-density 0.03 --forest-size 18 8 --person
  --person-lead "${PERSON_LEAD:--1.5}")
case $mode in
  forest) world=(--world-seed 21 --forest-density 0.08 --forest-size 14 8) peer=() ;;
  person) world=("${person[@]}") peer=(--cloud-topic cloud) ;;
  person-blind) world=("${person[@]}") peer=() ;;
  *) echo "FAIL: unknown mode $mode"; exit 1 ;;
esac

"$bin/mlmap_node" --config "$cfg" --report-every 5 > "$out/node.log" 2>&1 &
node=$!
"$bin/mlmap_planner_peer" --config "$cfg" --report-every 5 "${peer[@]}" > "$out/planner.log" 2>&1 &
planner=$!
trap 'kill $node $planner 2>/dev/null' EXIT

"$bin/mlmap_sensor_publisher" --config "$cfg" --closed-loop forest "${world[@]}" --timeout 45 \
  --wait-for-subscriber 20 > "$out/publisher.log" 2>&1
pub_rc=$?
kill -INT $planner
wait $planner
planner_rc=$?
kill -INT $node
wait $node
node_rc=$?
for f in publisher planner node; do echo "== $f"; cat "$out/$f.log"; done
echo "publisher $pub_rc, planner $planner_rc, node $node_rc"
[ $planner_rc -eq 0 ] && [ $node_rc -eq 0 ] || { echo "FAIL: the planner or the node failed"; exit 1; }
grep -q "closed loop: reached 1, collisions 0," "$out/publisher.log" ||
  { echo "FAIL: the vehicle did not reach the goal without collision"; exit 1; }
[ $pub_rc -eq 0 ] || { echo "FAIL: the sensor publisher failed"; exit 1; }
grep -q "map-to-plan (over DDS) median" "$out/planner.log" ||
  { echo "FAIL: the planner planned on no map of the node"; exit 1; }
grep -q "0 rejected, reached 1" "$out/planner.log" ||
  { echo "FAIL: the planner rejected a message or never saw the vehicle at the goal"; exit 1; }
if [ "$mode" = person ]; then
  grep -Eq "sensor frames: [0-9]+ clouds and 0 depth images received, [1-9][0-9]* gave their points" \
    "$out/planner.log" ||
    { echo "FAIL: no cloud's points reached the planner"; exit 1; }
fi
echo "PASS"
