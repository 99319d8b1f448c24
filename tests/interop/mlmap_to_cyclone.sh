#!/usr/bin/env bash
# mlmap (Fast DDS) -> Cyclone DDS, on loopback. mlmap_interop_talker publishes clouds and grids
# made by mlmap's encoders with the node's QoS; mlmap_cyclone_peer (types from idlc) records what
# it receives. Passes when the Cyclone reader got exactly the messages sent, every field and every
# data byte equal (a 4.8 MB cloud among them), each as XCDR1 little endian; when the latched grid
# reached it although it joined after the grid was written (only the last grid, as KEEP_LAST 1);
# and when it survived malformed payloads sent before the clouds, recording none of them.
#   mlmap_to_cyclone.sh <talker> <cyclone peer> <cyclone config xml> <out dir> <domain id>
set -uo pipefail
talker=$1 peer=$2 cyclone_xml=$3 out=$4
export ROS_DOMAIN_ID=$5
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # Fast DDS: never leave loopback
export CYCLONEDDS_URI=file://$cyclone_xml       # Cyclone: the same, with unicast discovery
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE   # a secured shell must not change what these tests check
rm -rf "$out" && mkdir -p "$out/sent" "$out/received"
fail() { echo "FAIL: $*"; exit 1; }
start=$(date +%s%N)

"$talker" --out "$out/sent" --ready-file "$out/ready" --wait 30 > "$out/talker.log" 2>&1 &
talker_pid=$!
peer_pid=
trap 'kill $talker_pid $peer_pid 2>/dev/null' EXIT
# The Cyclone reader joins late: only once the latched grids are written.
for _ in $(seq 300); do
  [ -e "$out/sent/latched.done" ] || ! kill -0 $talker_pid 2>/dev/null && break
  sleep 0.05
done
[ -e "$out/sent/latched.done" ] || { cat "$out/talker.log"; fail "the talker wrote no latched grid"; }
rm "$out/sent/latched.done"
"$peer" listen --out "$out/received" --ready-file "$out/ready" --cloud-writers 2 \
  --expect-clouds 5 --expect-grids 2 --timeout 40 > "$out/peer.log" 2>&1 &
peer_pid=$!
wait $talker_pid
talker_rc=$?
wait $peer_pid
peer_rc=$?
for f in talker peer; do echo "== $f"; cat "$out/$f.log"; done
echo "talker $talker_rc, cyclone peer $peer_rc, $(( ($(date +%s%N) - start) / 1000000 )) ms"
[ $talker_rc -eq 0 ] || fail "the talker failed"
[ $peer_rc -eq 0 ] || fail "the Cyclone peer failed (missing samples or not XCDR1 little endian)"

# The same set of messages on both sides (by stamp), then every record byte for byte.
sent=$(cd "$out/sent" && ls)
received=$(cd "$out/received" && ls)
[ "$(echo "$sent" | wc -w)" -eq 7 ] || fail "expected 7 records of sent messages, got: $sent"
[ "$sent" = "$received" ] ||
  fail "sent and received differ: $(diff <(echo "$sent") <(echo "$received") | tr '\n' ' ')"
for f in $sent; do
  cmp "$out/sent/$f" "$out/received/$f" || fail "$f differs"
done
large=$(find "$out/received" -name 'cloud_*' -size +4800000c | wc -l)
[ "$large" -eq 1 ] || fail "no 4.8 MB cloud among the records"
bytes=$(cat "$out"/received/* | wc -c)
echo "PASS: $(echo "$sent" | wc -w) messages identical on both sides ($bytes bytes of records)"
