# shellcheck shell=bash
# Network namespaces for the tests that need more than loopback (sourced; needs root).
# Each namespace lives as long as a process holding it (no `ip netns add`: it needs / to be a
# mount point, which a chroot's is not); `in_ns PID CMD...` runs CMD in it. Every pid the caller
# adds to `pids` (the namespace holders are added here) is killed when the script exits.

pids=()
netns_cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
  wait 2>/dev/null
}
trap netns_cleanup EXIT

# netns_new: starts a holder of a new network namespace, adds it to pids, sets netns_pid to it.
# Never configures the host's own network: exits the test when unshare made no namespace.
netns_new() {
  unshare -n sleep 3600 &
  local holder=$!
  pids+=("$holder")
  for _ in $(seq 100); do
    [ "$(readlink /proc/$holder/ns/net)" != "$(readlink /proc/self/ns/net)" ] && break
    sleep 0.05
  done
  [ "$(readlink /proc/$holder/ns/net)" != "$(readlink /proc/self/ns/net)" ] ||
    { echo "FAIL: unshare -n made no network namespace"; exit 1; }
  # shellcheck disable=SC2034  # read by the script that sources this file
  netns_pid=$holder
}

# Runs CMD in the namespace. In the background, call nsenter itself instead (`nsenter -t NS -n
# CMD &`): nsenter execs CMD, so $! is the program's pid and the cleanup reaches it.
in_ns() { local ns=$1; shift; nsenter -t "$ns" -n "$@"; }

# netns_lan N TAG NET: a LAN of N hosts: a hub namespace holding a bridge TAGbr with address
# NET.254/24 (a ground station or a server runs there), and N namespaces, host k on a veth pair
# into the bridge with address NET.k/24, multicast on (discovery multicast stays on the bridge).
# Sets lan_hub (the hub's holder pid), lan_ns (the hosts' holder pids, host k at index k-1) and
# lan_dev (their interfaces).
netns_lan() {
  local n=$1 tag=$2 net=$3 k
  # shellcheck disable=SC2034  # lan_hub, lan_ns and lan_dev are read by the sourcing script
  netns_new; lan_hub=$netns_pid
  in_ns "$lan_hub" ip link set lo up
  in_ns "$lan_hub" ip link add "${tag}br" type bridge
  in_ns "$lan_hub" ip addr add "$net.254/24" dev "${tag}br"
  in_ns "$lan_hub" ip link set "${tag}br" up multicast on
  in_ns "$lan_hub" ip route add 224.0.0.0/4 dev "${tag}br"
  lan_ns=() lan_dev=()
  for k in $(seq "$n"); do
    netns_new
    ip link add "${tag}v$k" type veth peer name "${tag}h$k"
    ip link set "${tag}v$k" netns "$netns_pid"
    ip link set "${tag}h$k" netns "$lan_hub"
    in_ns "$lan_hub" ip link set "${tag}h$k" master "${tag}br" up
    in_ns "$netns_pid" ip link set lo up
    in_ns "$netns_pid" ip addr add "$net.$k/24" dev "${tag}v$k"
    in_ns "$netns_pid" ip link set "${tag}v$k" up multicast on
    in_ns "$netns_pid" ip route add 224.0.0.0/4 dev "${tag}v$k"
    # shellcheck disable=SC2034
    lan_ns+=("$netns_pid") lan_dev+=("${tag}v$k")
  done
}
