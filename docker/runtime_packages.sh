#!/usr/bin/env bash
# Prints the Debian packages that hold the shared libraries PROGRAM loads (ldd, so the libraries
# of its libraries too), one a line, without their architecture: what the onboard image's
# runtime stage installs, so that it holds no compiler, no -dev package and no list to keep up
# to date by hand. Run where PROGRAM was built (the image's build stage):
#   bash docker/runtime_packages.sh build/mlmap_node
set -euo pipefail
if [ $# -ne 1 ] || [ ! -x "$1" ]; then
  echo "usage: $0 PROGRAM (an executable)" >&2
  exit 2
fi
if ldd "$1" | grep -q 'not found'; then
  ldd "$1" >&2
  echo "$0: $1 needs a library that is not installed" >&2
  exit 1
fi
# Debian 12 merges /lib into /usr/lib, and dpkg knows each file by the path its package ships
# it under: look up the path ldd prints, then its /usr form, then the file it links to.
owner() {
  local path
  for path in "$1" "/usr$1" "$(readlink -f "$1")"; do
    dpkg-query -S "$path" 2>/dev/null | head -n 1 | cut -d: -f1 && return 0
  done
  echo "$0: no Debian package holds $1" >&2
  return 1
}
ldd "$1" | awk '$2 == "=>" && $3 ~ /^\// { print $3 }' | while read -r lib; do
  owner "$lib"
done | sort -u
