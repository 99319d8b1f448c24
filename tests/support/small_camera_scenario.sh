#!/usr/bin/env bash
# Writes config/worlds/default_room.yaml with a 160 x 120 camera (same field of view) to FILE, for
# the process tests whose subject is the link, not the image: rendering 640 x 480 frames under
# the sanitizers would set their pace.
#   bash tests/support/small_camera_scenario.sh FILE
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
sed -e 's/^  width: 640 /  width: 160 /; s/^  height: 480 /  height: 120 /' \
    -e 's/^  fx: 385.0 /  fx: 96.25 /; s/^  fy: 385.0 /  fy: 96.25 /' \
    -e 's/^  cx: 319.5 /  cx: 79.5  /; s/^  cy: 239.5 /  cy: 59.5  /' \
    "$repo/config/worlds/default_room.yaml" > "$1"
# Every one of the six lines must have been replaced (else the field of view would change).
[ "$(grep -cE '^  (width: 160|height: 120|fx: 96.25|fy: 96.25|cx: 79.5|cy: 59.5) ' "$1")" -eq 6 ] ||
  { echo "could not shrink the camera of default_room.yaml (its camera lines changed?)" >&2; exit 1; }
