#!/usr/bin/env bash
# Builds mlmap's onboard and simulation images with podman on this machine, with no registry:
#  1. installs podman, runc and debootstrap when missing (tools/install_deps.sh --containers);
#  2. makes the base image `debian:12` once per machine, if there is none: debootstrap
#     --variant=minbase bookworm from the Debian mirror of this machine's apt sources, imported
#     with `podman import` (every FROM of docker/onboard.Dockerfile and docker/sim.Dockerfile
#     resolves to it; nothing is pulled);
#  3. checks that podman can start a container at all (exit 77 with the reason where it cannot);
#  4. builds mlmap-onboard and mlmap-sim from docker/*.Dockerfile, tagged with a key: a hash of
#     the Dockerfiles and every file they copy, and of the base image. Images of the same key are
#     reused as they are; otherwise podman builds, reusing the layers it has cached (a new machine
#     builds from scratch). Each image is also tagged `latest`.
# Prints the time of each step and the images' sizes.
#   bash tools/container_images.sh                  build (or reuse) both images
#   bash tools/container_images.sh --env FILE       and write onboard=IMAGE, sim=IMAGE to FILE
# podman runs with runc and cgroupfs and docker/podman/containers.conf (CONTAINERS_CONF): the
# settings this kind of machine needs; builds use the host's network (apt-get in the builds).
# Needs root (podman's storage under /var/lib/containers, debootstrap).
set -euo pipefail
cd "$(dirname "$0")/.."
env_file=""
case "${1:-}" in
  "") ;;
  --env) env_file=${2:?--env needs a file}; shift 2 ;;
  *) echo "usage: $0 [--env FILE]" >&2; exit 2 ;;
esac
[ $# -eq 0 ] || { echo "usage: $0 [--env FILE]" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] || { echo "$0: needs root (podman's storage, debootstrap)" >&2; exit 1; }

bash tools/install_deps.sh --containers
export CONTAINERS_CONF=$PWD/docker/podman/containers.conf
pm() { podman --runtime runc --cgroup-manager=cgroupfs "$@"; }

step_start=$SECONDS
step() {  # step NAME: prints how long the step that just ended took
  printf '   %-44s %4d s\n' "$1" $((SECONDS - step_start))
  step_start=$SECONDS
}

# The first Debian mirror this machine's apt sources give for SUITE (one-line or deb822 format).
debian_mirror() {
  local suite=$1 file
  for file in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [ -f "$file" ] || continue
    sed -E 's/\[[^]]*\]//' "$file" | awk -v s="$suite" '$1 == "deb" && $3 == s { print $2; exit }'
  done
  for file in /etc/apt/sources.list.d/*.sources; do
    [ -f "$file" ] || continue
    # deb822: paragraphs of Types, URIs, Suites...; the first URI of a paragraph naming SUITE.
    awk -v s="$suite" 'BEGIN { RS = ""; FS = "\n" }
      { uri = ""; hit = 0; deb = 0
        for (i = 1; i <= NF; i++) {
          split($i, kv, ":[ \t]*"); key = kv[1]; value = substr($i, length(key) + 2)
          if (key == "Types" && value ~ /(^|[ \t])deb([ \t]|$)/) deb = 1
          if (key == "URIs") { split(value, u, /[ \t]+/); uri = (u[1] != "" ? u[1] : u[2]) }
          if (key == "Suites") { n = split(value, w, /[ \t]+/); for (j = 1; j <= n; j++) if (w[j] == s) hit = 1 }
        }
        if (deb && hit && uri != "") { print uri; exit } }' "$file"
  done | head -n 1
}

echo "== container images (podman $(podman --version | awk '{print $3}'), runc, cgroupfs)"
if ! pm image exists debian:12; then
  mirror=${MLMAP_DEBIAN_MIRROR:-$(debian_mirror bookworm)}
  [ -n "$mirror" ] || { echo "$0: no Debian bookworm mirror in /etc/apt/sources.list*; set MLMAP_DEBIAN_MIRROR" >&2; exit 1; }
  updates=$(debian_mirror bookworm-updates) security=$(debian_mirror bookworm-security)
  rootfs=$(mktemp -d /var/tmp/mlmap-debian12.XXXXXX)
  trap 'rm -rf "$rootfs"' EXIT
  echo "   base image debian:12: debootstrap --variant=minbase bookworm from $mirror"
  debootstrap --variant=minbase bookworm "$rootfs" "$mirror" > "$rootfs.log" 2>&1 ||
    { tail -n 20 "$rootfs.log" >&2; echo "$0: debootstrap failed (log: $rootfs.log)" >&2; exit 1; }
  rm -f "$rootfs.log"
  # The builds' apt-get sees what this machine's does: the release, its updates and security.
  {
    echo "deb $mirror bookworm main"
    if [ -n "$updates" ]; then echo "deb $updates bookworm-updates main"; fi
    if [ -n "$security" ]; then echo "deb $security bookworm-security main"; fi
  } > "$rootfs/etc/apt/sources.list"
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
  tar -C "$rootfs" -c . | pm import --quiet --change 'CMD ["bash"]' \
    --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' - debian:12 > /dev/null
  rm -rf "$rootfs"
  trap - EXIT
  step "base image (debootstrap + import)"
else
  echo "   base image debian:12: there already"
fi

# Can podman start a container at all? Where it cannot, the reason, and exit 77 (a skip).
if ! started=$(pm run --rm --network none debian:12 true 2>&1); then
  echo "SKIP: podman cannot start a container on this machine: $(tail -n 1 <<<"$started")"
  exit 77
fi

# The key: the Dockerfiles, every file their COPY instructions take from the build context (the
# files git tracks or would track there: no build output) and the base image.
git rev-parse --git-dir > /dev/null 2>&1 ||
  { echo "$0: needs a git checkout (the images' key hashes the files git tracks or would track)" >&2; exit 1; }
base_id=$(pm image inspect --format '{{.Id}}' debian:12)
dockerfiles=(docker/onboard.Dockerfile docker/sim.Dockerfile)
mapfile -t copied < <(awk '$1 == "COPY" && $2 !~ /^--from/ { for (i = 2; i < NF; i++) print $i }' \
                        "${dockerfiles[@]}" | sort -u)
sources=("${dockerfiles[@]}" .dockerignore "${copied[@]}")
key=$({
  echo "$base_id"
  git ls-files -z --cached --others --exclude-standard -- "${sources[@]}" | sort -zu |
    while IFS= read -r -d '' f; do if [ -f "$f" ]; then sha256sum "$f"; fi; done   # (not deleted ones)
} | sha256sum | cut -c1-16)

build() {  # build NAME DOCKERFILE: mlmap-NAME:KEY, built unless it exists
  local image="mlmap-$1:$key"
  if pm image exists "$image"; then
    echo "   $image: reused (built before from the same files)"
  else
    echo "   $image: building from $2 (log: $log_dir/$1.log)"
    # Each line of the log with its time, for where the build's time goes.
    if ! pm build --network host --pull=never -f "$2" -t "$image" . 2>&1 |
         while IFS= read -r line; do printf '%(%T)T %s\n' -1 "$line"; done > "$log_dir/$1.log"; then
      tail -n 30 "$log_dir/$1.log" >&2
      echo "$0: podman build of $2 failed (log: $log_dir/$1.log)" >&2
      exit 1
    fi
    step "build mlmap-$1"
  fi
  pm tag "$image" "mlmap-$1:latest"
  # Other keys' tags go once a day old (another tree of the same machine may be using a newer
  # one); their layers stay in podman's cache for another day, for the next build.
  pm images --format '{{.Repository}}:{{.Tag}}' --filter "reference=mlmap-$1" --filter until=24h |
    grep -v -e ":$key\$" -e ':latest$' | xargs -r podman --runtime runc --cgroup-manager=cgroupfs rmi > /dev/null 2>&1 || true
}
log_dir=build-containers
mkdir -p "$log_dir"
build onboard docker/onboard.Dockerfile
build sim docker/sim.Dockerfile
pm image prune -f --filter until=24h > /dev/null 2>&1 || true

for name in onboard sim; do
  size=$(pm image inspect --format '{{.Size}}' "mlmap-$name:$key")
  printf '   %-44s %4d MB\n' "mlmap-$name:$key" $((size / 1000000))
done
if [ -n "$env_file" ]; then
  printf 'onboard=mlmap-onboard:%s\nsim=mlmap-sim:%s\n' "$key" "$key" > "$env_file"
fi
