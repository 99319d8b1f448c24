# shellcheck shell=bash
# Network namespaces for the tests that need more than loopback (sourced; needs root).
# Each namespace lives as long as a process holding it (no `ip netns add`: it needs / to be a
# mount point, which a chroot's is not); `in_ns PID CMD...` runs CMD in it and execs, so $! of a
# backgrounded in_ns is the program's pid and signals reach it. Every pid the caller adds to
# `pids` (the namespace holders are added here) is killed when the script exits.

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

in_ns() { local ns=$1; shift; nsenter -t "$ns" -n "$@"; }
