#!/usr/bin/env bash
# How long a newly started participant takes to see mlmap_node's endpoints on loopback, as a
# one-shot ROS 2 command (`ros2 topic info --no-daemon`, which waits 0.5 s) does: mlmap_node runs;
# 15 times, a Fast DDS participant in a process of its own (mlmap_dds_tests' DiscoveryProbe) and,
# when built, a Cyclone DDS one (mlmap_cyclone_peer discover) start and time until they know the
# node's status writer. Prints the times (median, max, how many over 0.1 s and 0.5 s). Fails when
# a participant needed 0.5 s or more (a one-shot command would miss the node): without the node's
# DiscoveryPacing, 3 of 15 Fast DDS and 1-5 of 15 Cyclone participants did.
#   discovery_latency.sh <bin dir> <dds tests binary> <cyclone peer or ""> <domain id>
set -uo pipefail
bin=$1 tests=$2 cyclone=$3 domain=$4
here=$(cd "$(dirname "$0")" && pwd)
runs=15
export ROS_DOMAIN_ID=$domain ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export CYCLONEDDS_URI="file://$here/../../config/dds/cyclone_loopback.xml"
unset ROS_STATIC_PEERS FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE
log=$(mktemp)
"$bin/mlmap_node" --report-every 0 > "$log" 2>&1 &
node=$!
trap 'kill -9 $node 2>/dev/null; rm -f "$log"' EXIT
for _ in $(seq 100); do grep -q "mapping on DDS domain" "$log" && break; sleep 0.1; done
grep -q "mapping on DDS domain" "$log" || { cat "$log"; echo "FAIL: mlmap_node did not start"; exit 1; }
sleep 1

summary() {  # name, then times [ms] on stdin: "name: median X ms, max Y ms (n runs)"
  sort -n | awk -v name="$1" '{t[NR]=$1} END {
    if (NR == 0) { print name ": no run"; exit }
    printf "%s: median %.1f ms, max %.1f ms, over 100 ms in %d and over 500 ms in %d of %d runs\n",
      name, (NR % 2 ? t[(NR+1)/2] : (t[NR/2]+t[NR/2+1])/2), t[NR], slow(t, NR, 100),
      slow(t, NR, 500), NR }
    function slow(t, n, ms,   i, c) { c = 0; for (i = 1; i <= n; ++i) if (t[i] >= ms) ++c; return c }'
}
fastdds=()
for _ in $(seq $runs); do
  t=$(MLMAP_PROBE_DOMAIN=$domain "$tests" --gtest_filter=DiscoveryProbe.* 2>/dev/null |
      sed -n 's/^PROBE \([0-9.]*\)$/\1/p')
  fastdds+=("${t:-10000}")
  sleep 0.4
done
printf '%s\n' "${fastdds[@]}" | summary "Fast DDS 2.9 participant sees mlmap_node's writers"
cyclonedds=()
if [ -n "$cyclone" ]; then
  for _ in $(seq $runs); do
    t=$("$cyclone" discover --topic rt/mlmap/status --timeout 10 |
        sed -n 's/.* after \([0-9.]*\) ms.*/\1/p')
    cyclonedds+=("${t:-10000}")
    sleep 0.4
  done
  printf '%s\n' "${cyclonedds[@]}" | summary "Cyclone DDS participant sees mlmap_node's writers"
fi
kill -INT $node; wait $node || { cat "$log"; echo "FAIL: mlmap_node did not stop cleanly"; exit 1; }
status=0
for vendor in fastdds cyclonedds; do
  declare -n times=$vendor
  [ ${#times[@]} -gt 0 ] || continue
  slow=$(printf '%s\n' "${times[@]}" | awk '$1 >= 500' | wc -l)
  [ "$slow" -eq 0 ] || { echo "FAIL: $slow of $runs new $vendor participants needed 0.5 s or more"; status=1; }
done
[ $status -eq 0 ] && echo "OK"
exit $status
