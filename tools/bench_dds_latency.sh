#!/usr/bin/env bash
# The DDS latency benchmark: mlmap_sensor_publisher streams 640 x 480 organised clouds (307,200
# points x 16 B = 4.9 MB) at 30 Hz to mlmap_node, and mlmap_bench_dds_latency measures, at a
# subscriber of the local-map layer, capture -> local map latency (p50, p99) and dropped frames,
# once with data-sharing (the default), once over UDP only (as from a ROS 2 driver) and once over
# the shared-memory transport (dds.shared_memory, off by default), on loopback. Prints the
# figures against the targets (no dropped frame; p50 <= engine compute median + 5 ms; p99 <=
# engine p99 + 15 ms).
# Figures, not a test: only --smoke fails, when a frame sent did not reach the subscriber.
# With --secure every mode runs twice, without and with DDS Security, and the cost of
# encryption is printed (target: under 20 % more latency).
#
#   tools/bench_dds_latency.sh [--build DIR] [--out DIR] [--seconds S] [--rate HZ]
#                              [--modes "datasharing udp shm"] [--domain ID] [--probe-cloud] [--smoke]
#                              [--secure] [--protection full|payload|link|link-signed]
#                              [--keystore DIR]
#
#   --build DIR    where the programs are (default: build-perf)
#   --out DIR      logs, node configs, latency_<mode>.json (default: bench_output/dds_latency)
#   --seconds S    seconds of streaming per mode (default 25)
#   --rate HZ      frames per second (default 30)
#   --modes LIST   datasharing: the default configuration (LOCALHOST: UDPv4 on 127.0.0.1 with 4 MB
#                    buffers; the clouds by data-sharing, the rest through UDP);
#                  udp: the same with dds.data_sharing false (the clouds through UDP, as from a
#                    ROS 2 driver);
#                  shm: dds.shared_memory true (+ the SHM transport, 16 MB segment) and
#                    dds.data_sharing false (the clouds through the SHM transport; only between
#                    Fast DDS 2.9 peers)
#   --domain ID    DDS domain of every run, one after the other (default 135; keep to 135..139)
#   --probe-cloud  the subscriber also times the clouds' own transport (adds a second reader)
#   --smoke        check, not measure: deep queues so a loaded machine delays rather than drops,
#                  and fail unless every frame reached the subscriber and the node mapped it all
#   --secure       also run every mode with DDS Security (label <mode>+sec): the node as enclave
#                  /mlmap/node, the sensor publisher as /mlmap/sensor, the subscriber as
#                  /ground/monitor of the test keystore (governance: everything ENCRYPT)
#   --protection P the test keystore's governance: full (default: rtps, metadata and data
#                  ENCRYPT), payload (data ENCRYPT only), link (data ENCRYPT only, the onboard
#                  sensor streams access control only) or link-signed (those signed); see
#                  tools/make_test_keystore.sh
#   --keystore DIR the SROS2 keystore for --secure (default: made by tools/make_test_keystore.sh
#                  --protection P in <out>/keystore_<P>)
set -uo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
bin=$repo/build-perf out=$repo/bench_output/dds_latency seconds=25 rate=30 modes="datasharing udp shm"
domain=135 probe=() smoke=0 security="off" keystore="" protection=full
while [ $# -gt 0 ]; do
  case $1 in
    --build) bin=$(cd "$2" && pwd); shift 2 ;;
    --out) out=$2; shift 2 ;;
    --seconds) seconds=$2; shift 2 ;;
    --rate) rate=$2; shift 2 ;;
    --modes) modes=$2; shift 2 ;;
    --domain) domain=$2; shift 2 ;;
    --probe-cloud) probe=(--probe-cloud); shift ;;
    --smoke) smoke=1; shift ;;
    --secure) security="off on"; shift ;;
    --keystore) keystore=$2; shift 2 ;;
    --protection) protection=$2; shift 2 ;;
    *) echo "unknown option $1 (see the comment at the top of $0)" >&2; exit 64 ;;
  esac
done
for p in mlmap_node mlmap_sensor_publisher mlmap_bench_dds_latency; do
  [ -x "$bin/$p" ] || { echo "no $bin/$p: build first (cmake --build $bin)" >&2; exit 2; }
done
frames=$(awk -v s="$seconds" -v r="$rate" 'BEGIN { printf "%d", s * r }')
[ "$frames" -gt 0 ] || { echo "--seconds x --rate gives no frame" >&2; exit 64; }
require=(); [ $smoke -eq 1 ] && require=(--require-all)

export ROS_DOMAIN_ID=$domain
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # never leave loopback
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_SECURITY_ENABLE ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY \
  ROS_SECURITY_ENCLAVE_OVERRIDE
mkdir -p "$out"
given_keystore=$keystore
if [ "$security" != off ] && [ -z "$keystore" ]; then
  keystore=$out/keystore_$protection
  "$repo/tools/make_test_keystore.sh" "$keystore" --protection "$protection" > "$out/keystore.log" ||
    { cat "$out/keystore.log"; echo "cannot make the test keystore" >&2; exit 2; }
fi
[ -z "$keystore" ] || keystore=$(cd "$keystore" && pwd)
pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done' EXIT
load() { cut -d' ' -f1-3 /proc/loadavg; }
hwm_mb() { awk '/VmHWM/ { printf "%.0f", $2 / 1024 }' "/proc/$1/status" 2>/dev/null; }

results=() status=0
echo "DDS latency benchmark: $frames frames at $rate Hz per mode ($modes; security $security), domain $domain, $(nproc) cores"
for run in $(for m in $modes; do for s in $security; do echo "$m:$s"; done; done); do
  mode=${run%%:*} sec=${run#*:}
  label=$mode; [ "$sec" = on ] && label=$mode+sec
  # Each program its own enclave (the config leaves the enclave to the environment).
  node_env=() pub_env=() sub_env=()
  if [ "$sec" = on ]; then
    node_env=(ROS_SECURITY_ENCLAVE_OVERRIDE=/mlmap/node)
    pub_env=(ROS_SECURITY_ENCLAVE_OVERRIDE=/mlmap/sensor)
    sub_env=(ROS_SECURITY_ENCLAVE_OVERRIDE=/ground/monitor)
  fi
  dir=$out/$label
  rm -rf "$dir" && mkdir -p "$dir"
  cfg=$dir/node.yaml
  # Every snapshot published (local_map_hz above the frame rate); everything else as deployed.
  {
    [ $smoke -eq 1 ] && printf 'pipeline: {input_queue_capacity: 64}\n'
    printf 'dds:\n  rates: {local_map_hz: 100.0, status_hz: 2.0}\n'
    case $mode in
      datasharing) ;;
      udp) printf '  data_sharing: false\n' ;;
      shm) printf '  data_sharing: false\n  shared_memory: true\n' ;;
      *) echo "unknown mode $mode (datasharing, shm, udp)" >&2; exit 64 ;;
    esac
    [ "$sec" = on ] && printf '  security: {enable: true, keystore: %s, strategy: Enforce}\n' "$keystore"
  } > "$cfg"
  load_before=$(load)

  env "${node_env[@]}" "$bin/mlmap_node" --config "$cfg" --report-every 0 > "$dir/node.log" 2>&1 &
  node=$!
  env "${sub_env[@]}" "$bin/mlmap_bench_dds_latency" --config "$cfg" --frames "$frames" --label "$label" \
    --json "$out/latency_$label.json" --idle-stop 3 --duration $((seconds * 4 + 180)) "${probe[@]}" \
    "${require[@]}" > "$dir/bench.log" 2>&1 &
  bench=$!
  pids=("$node" "$bench")
  for _ in $(seq 200); do grep -qs '^ready' "$dir/bench.log" && break; sleep 0.1; done
  grep -q '^ready' "$dir/bench.log" || echo "warning: the subscriber did not match the node in 20 s"

  env "${pub_env[@]}" "$bin/mlmap_sensor_publisher" --config "$cfg" --rate "$rate" --max-frames "$frames" --prerender \
    > "$dir/publisher.log" 2>&1 &
  pub=$!
  pids+=("$pub")
  pub_mb=0
  while kill -0 $pub 2>/dev/null; do
    m=$(hwm_mb $pub); [ -n "$m" ] && pub_mb=$m
    sleep 0.5
  done
  wait $pub
  pub_rc=$?
  node_mb=$(hwm_mb $node)
  load_after=$(load)
  kill -INT $node
  wait $node
  node_rc=$?
  wait $bench
  bench_rc=$?
  pids=()

  echo
  echo "== $label: load average (1/5/15 min) before the run $load_before, at the end of streaming $load_after"
  sed -n '/^== /,$p' "$dir/bench.log" | grep -v '^result '
  grep -E 'done:|late|error|warn' "$dir/publisher.log" | sed 's/^/publisher: /'
  grep -E 'done:|error|warn' "$dir/node.log" | sed 's/^/node: /' | head -20
  echo "peak memory: node ${node_mb:-?} MB, publisher ${pub_mb} MB (prerendered frames)"
  line=$(grep '^result ' "$dir/bench.log")
  results+=("$line node_mb=${node_mb:-?} load=${load_before%% *}/${load_after%% *}")
  mapped=$(sed -n 's/.*done: \([0-9]*\) frames mapped.*/\1/p' "$dir/node.log")
  if [ $pub_rc -ne 0 ] || [ $node_rc -ne 0 ] || [ $bench_rc -ne 0 ]; then
    echo "FAIL ($label): publisher $pub_rc, node $node_rc, subscriber $bench_rc"
    status=1
  fi
  if [ $smoke -eq 1 ] && [ "${mapped:-0}" -ne "$frames" ]; then
    echo "FAIL ($label): the node mapped ${mapped:-no} frames of $frames"
    status=1
  fi
done

echo
echo "== Summary: capture -> local map at the subscriber, $frames frames of 640x480 at $rate Hz per mode"
declare -A p50_of p99_of
printf '%-8s %6s %7s %9s %8s %8s %8s %11s %11s %7s %7s  %s\n' mode sent mapped received \
  p50_ms p99_ms max_ms engine_p50 engine_p99 "p50 ok" "p99 ok" "1-min load before/after"
for r in "${results[@]}"; do
  get() { echo "$r" | tr ' ' '\n' | sed -n "s/^$1=//p"; }
  mode=$(echo "$r" | cut -d' ' -f2)
  p50=$(get p50) p99=$(get p99) e50=$(get engine_p50) e99=$(get engine_p99)
  ok50=$(awk -v a="$p50" -v b="$e50" 'BEGIN { print (a <= b + 5) ? "yes" : "NO" }')
  ok99=$(awk -v a="$p99" -v b="$e99" 'BEGIN { print (a <= b + 15) ? "yes" : "NO" }')
  printf '%-8s %6s %7s %9s %8s %8s %8s %11s %11s %7s %7s  %s\n' "$mode" "$(get sent)" "$(get mapped)" \
    "$(get received)" "$p50" "$p99" "$(get max)" "$e50" "$e99" "$ok50" "$ok99" "$(echo "$r" | sed 's/.*load=//')"
  p50_of[$mode]=$p50 p99_of[$mode]=$p99
done
if [ "$security" != off ]; then
  echo
  case $protection in
    payload) what="discovery and data only" ;;
    link) what="discovery and the data of the link topics; clouds and images access control only" ;;
    link-signed) what="discovery and the data of the link topics; clouds and images signed only" ;;
    *) what="rtps, discovery, metadata and data" ;;
  esac
  [ -n "$given_keystore" ] && what="what the governance of $keystore says"
  echo "== Cost of DDS Security (PKI-DH, access control, AES-GCM-GMAC ENCRYPT on $what)"
  for mode in $modes; do
    [ -n "${p50_of[$mode]:-}" ] && [ -n "${p50_of[$mode+sec]:-}" ] || continue
    awk -v m="$mode" -v a="${p50_of[$mode]}" -v b="${p50_of[$mode+sec]}" -v c="${p99_of[$mode]}" \
        -v d="${p99_of[$mode+sec]}" 'BEGIN {
      printf "%-4s p50 %.1f -> %.1f ms (%+.0f %%), p99 %.1f -> %.1f ms (%+.0f %%); target < +20 %%: %s\n",
        m, a, b, 100 * (b - a) / a, c, d, 100 * (d - c) / c, (b <= 1.2 * a && d <= 1.2 * c) ? "yes" : "NO" }'
  done
fi
echo "targets: received = sent (no dropped frame); p50 <= engine_p50 + 5 ms; p99 <= engine_p99 + 15 ms"
echo "(latency figures leave out the first second of stamps; the per-mode tables above have every frame)"
echo "JSON: $out/latency_<mode>.json; logs: $out/<mode>/"
exit $status
