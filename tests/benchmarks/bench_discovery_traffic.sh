#!/usr/bin/env bash
# Discovery traffic of a fleet: N vehicles, each an mlmap_node (namespace uav<k>) in its own
# network namespace on one shared bridge (a LAN made here: nothing reaches the real interface),
# discovering each other with Fast DDS's simple discovery (SPDP multicast + SEDP unicast) or
# through a Discovery Server (`fastdds discovery`, fastdds-tools; config/dds/
# discovery_server_client.xml with the server's address on the bridge).
#
# The vehicles share no topic (their namespaces differ), so every byte on their links is
# discovery: participant announcements, endpoint announcements, liveliness, heartbeats and
# acknowledgements. The script counts each vehicle's link bytes (sent + received, `ip -s link`)
# while the vehicles join (--join seconds from the first start) and then at steady state
# (--steady seconds), and prints a table. Then it checks that discovery worked: for each vehicle
# a ground-station inspector (mlmap_inspect, in the server's namespace, with the same discovery)
# must receive that vehicle's status. Mode `noserver` is the control: the same clients with no
# server running must see nothing (so the server mode's discovery went through the server).
#
#   bench_discovery_traffic.sh --bin DIR [--vehicles "2 4 8"] [--modes "simple server noserver"]
#                              [--join 10] [--steady 20] [--domain 137] [--out DIR]
# Needs root (unshare, nsenter, ip). Exits 1 when a run fails its discovery check.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
bin="" vehicles="2 4 8" modes="simple server" join_s=10 steady_s=20 domain=137 out=""
while [ $# -gt 0 ]; do
  case $1 in
    --bin) bin=$2; shift 2 ;;
    --vehicles) vehicles=$2; shift 2 ;;
    --modes) modes=$2; shift 2 ;;
    --join) join_s=$2; shift 2 ;;
    --steady) steady_s=$2; shift 2 ;;
    --domain) domain=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    *) echo "unknown option $1 (see the header of $0)"; exit 2 ;;
  esac
done
[ -x "$bin/mlmap_node" ] && [ -x "$bin/mlmap_inspect" ] ||
  { echo "FAIL: --bin must hold mlmap_node and mlmap_inspect"; exit 1; }
[ "$(id -u)" = 0 ] || { echo "FAIL: needs root for network namespaces"; exit 1; }
for tool in ip unshare nsenter fastdds /usr/bin/python3; do
  command -v "$tool" >/dev/null || { echo "FAIL: $tool missing (bash tools/install_deps.sh)"; exit 1; }
done
out=${out:-$(mktemp -d /tmp/mlmap_discovery.XXXXXX)}
mkdir -p "$out"
export ROS_DOMAIN_ID=$domain ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET
unset FASTRTPS_DEFAULT_PROFILES_FILE ROS_STATIC_PEERS ROS_DISCOVERY_SERVER ROS_SECURITY_ENABLE \
  ROS_SECURITY_KEYSTORE ROS_SECURITY_STRATEGY ROS_SECURITY_ENCLAVE_OVERRIDE
# shellcheck source=../support/netns.sh
source "$here/../support/netns.sh"   # pids, killed on exit; netns_lan; in_ns
lan_hub="" lan_ns=() lan_dev=()
server_ip=10.79.0.254

# link_bytes NS DEV: bytes sent + received on DEV in namespace NS so far.
link_bytes() {
  in_ns "$1" ip -j -s link show dev "$2" | /usr/bin/python3 -c \
    'import json, sys; s = json.load(sys.stdin)[0]["stats64"]; print(s["rx"]["bytes"] + s["tx"]["bytes"])'
}

# vehicle_config K MODE: the node's configuration of vehicle K (its namespace; the server's
# client profile in server mode).
vehicle_config() {
  local cfg="$run/uav$1.yaml"
  printf 'dds:\n  ns: uav%s\n' "$1" > "$cfg"
  if [ "$2" != simple ]; then
    printf '  profiles_file: %s\n  participant_profile: mlmap_discovery_client\n' \
      "$run/client.xml" >> "$cfg"
  fi
  echo "$cfg"
}

failures=0
printf '| discovery | vehicles | joining: bytes per vehicle (%s s) | steady: bytes/s per vehicle | steady: bytes/s, whole LAN | server link bytes/s | status of every vehicle seen |\n' "$join_s"
printf '|---|---|---|---|---|---|---|\n'
for mode in $modes; do
  for n in $vehicles; do
    run="$out/${mode}_$n"
    rm -rf "$run" && mkdir -p "$run"
    netns_lan "$n" "mld$$" 10.79.0   # the vehicles at 10.79.0.k, the hub (server) at .254
    hub=$lan_hub vehicle_ns=("${lan_ns[@]}") vehicle_dev=("${lan_dev[@]}")
    sed "s|<address>127.0.0.1</address>|<address>$server_ip</address>|" \
      "$repo/config/dds/discovery_server_client.xml" > "$run/client.xml"
    run_pids=()
    if [ "$mode" = server ]; then
      # nsenter itself (not in_ns) in the background: it execs, so $! is the program's pid.
      nsenter -t "$hub" -n fastdds discovery -i 0 -l "$server_ip" -p 11811 > "$run/server.log" 2>&1 &
      run_pids+=("$!"); pids+=("$!")
      sleep 1
    fi
    declare -A before=()
    for k in $(seq "$n"); do before[$k]=$(link_bytes "${vehicle_ns[k-1]}" "${vehicle_dev[k-1]}"); done
    for k in $(seq "$n"); do
      cfg=$(vehicle_config "$k" "$mode")
      nsenter -t "${vehicle_ns[k-1]}" -n "$bin/mlmap_node" --config "$cfg" --report-every 0 \
        > "$run/uav$k.log" 2>&1 &
      run_pids+=("$!"); pids+=("$!")
    done
    sleep "$join_s"
    joined=0
    declare -A middle=()
    for k in $(seq "$n"); do
      middle[$k]=$(link_bytes "${vehicle_ns[k-1]}" "${vehicle_dev[k-1]}")
      joined=$((joined + middle[$k] - before[$k]))
    done
    server_middle=$(link_bytes "$hub" "mld$$br")
    sleep "$steady_s"
    steady=0
    for k in $(seq "$n"); do
      now=$(link_bytes "${vehicle_ns[k-1]}" "${vehicle_dev[k-1]}")
      steady=$((steady + now - middle[$k]))
    done
    server_after=$(link_bytes "$hub" "mld$$br")
    # Did discovery work? A ground station on the LAN (same discovery) gets each vehicle's status.
    seen=0
    for k in $(seq "$n"); do
      cfg=$(vehicle_config "$k" "$mode")
      if in_ns "$hub" "$bin/mlmap_inspect" --config "$cfg" --duration 8 --idle-stop 1 \
        --expect mlmap/status > "$run/inspect_uav$k.log" 2>&1; then
        seen=$((seen + 1))
      fi
    done
    for p in "${run_pids[@]}"; do kill "$p" 2>/dev/null; done
    for p in "${run_pids[@]}"; do wait "$p" 2>/dev/null; done
    expected=$n
    [ "$mode" = noserver ] && expected=0
    [ "$seen" = "$expected" ] || failures=$((failures + 1))
    server_rate="-"
    # The bridge's own counters see what crosses it as the server's link (server mode only).
    [ "$mode" = server ] && server_rate=$(( (server_after - server_middle) / steady_s ))
    printf '| %s | %s | %s | %s | %s | %s | %s of %s (expected %s) |\n' "$mode" "$n" \
      "$((joined / n))" "$((steady / n / steady_s))" "$((steady / steady_s))" "$server_rate" \
      "$seen" "$n" "$expected"
    netns_cleanup
    pids=()
  done
done
echo "runs' logs: $out"
[ "$failures" = 0 ] || { echo "FAIL: $failures run(s) where the ground station did not see what the discovery allows"; exit 1; }
