#!/usr/bin/env bash
# ctest mlmap_compare_octomap_smoke: the OctoMap comparison on a few frames of every dataset,
# then the plot script on its output. Fails when a mapper did not run, when OctoMap's keys do
# not map to mlmap's voxel indices (the program exits non-zero), when the two maps disagree
# even within one cell, when --stream-hz does not give consecutive frames, when a chart is
# missing, when the whole-process runs from files (mlmap_replay and the OctoMap replay) disagree,
# or when a bad --cases is not refused.
# Usage: compare_octomap_smoke.sh BUILD_DIR SOURCE_DIR WORK_DIR
set -euo pipefail
build=$1 source=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
"$build/mlmap_compare_octomap" --cases realsense:0.05,depth:0.2,lidar:0.3,building:0.2 --frames 2 \
  --out "$work/results" --voxels --quiet | tee "$work/compare.txt"
/usr/bin/python3 - "$work/results/compare.json" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
cases = data['cases']
assert [c['dataset'] for c in cases] == ['realsense', 'depth', 'lidar', 'building'], cases
for c in cases:
    name = c['name']
    assert c['frames'] == 2 and len(c['mlmap']['frame_ms']) == 2, name
    assert len(c['octomap']['frame_ms']) == 2, name
    assert c['points_per_frame'] > 10000, (name, c['points_per_frame'])
    assert c['octomap']['key_check']['leaves'] > 100, name
    assert c['octomap']['key_check']['mismatches'] == 0, name
    a = c['agreement']
    assert a['mlmap_voxels'] > 100 and a['octomap_voxels'] > 100, (name, a)
    assert a['precision_1'] > 0.95 and a['recall_1'] > 0.95, (name, a)
    assert c['mlmap']['peak_memory_bytes'] > 0 and c['octomap']['peak_memory_bytes'] > 0, name
    if c['dataset'] != 'realsense':
        t = c['truth']
        assert t['mlmap_right'] > 0.95 * a['mlmap_voxels'], (name, t)
        assert t['octomap_right'] > 0.95 * a['octomap_voxels'], (name, t)
print('compare.json: 4 cases, keys and agreement checked')
PY
# --stream-hz: consecutive frames at the sensor's rate from the start of the flight, not spread.
"$build/mlmap_compare_octomap" --cases depth:0.3 --stream-hz 10 --frames 3 --mappers mlmap \
  --out "$work/stream" --quiet > "$work/stream.txt"
/usr/bin/python3 - "$work/stream/compare.json" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))['cases'][0]
assert c['frames'] == 3 and 'streamed at 10 Hz' in c['description'], c['description']
path = c['path_m']
assert path[0] == 0.0 and all(0.0 < b - a < 0.5 for a, b in zip(path, path[1:])), path
print('--stream-hz: 3 consecutive frames, path', path)
PY
/usr/bin/python3 "$source/tools/plot_octomap_comparison.py" "$work/results" --out "$work/png"
for png in octomap_time octomap_memory octomap_agreement octomap_diff_realsense_0.05 \
           octomap_diff_building_0.20; do
  test -s "$work/png/$png.png" || { echo "missing $png.png" >&2; exit 1; }
done
# Whole-process runs from files: the frames written once, mapped by mlmap_replay and by the
# OctoMap replay; both read the same files and their maps agree within one cell.
"$build/mlmap_compare_octomap" --cases depth:0.2,lidar:0.2 --stream-hz 10 --frames 3 \
  --write-frames "$work/files" --quiet > "$work/files.txt"
"$build/mlmap_replay" --frames "$work/files/depth" --resolution 0.2 --max-range 10 \
  --out "$work/replay_depth" > "$work/replay_depth.txt" 2>&1
"$build/mlmap_compare_octomap" --octomap-frames "$work/files/depth" --octomap-resolution 0.2 \
  --max-range 10 --octomap-voxels "$work/octomap_depth.txt" > "$work/octomap_depth.log"
"$build/mlmap_replay" --clouds "$work/files/lidar/clouds" --poses "$work/files/lidar/poses.tum" \
  --resolution 0.2 --max-range 8 --out "$work/replay_lidar" > "$work/replay_lidar.txt" 2>&1
"$build/mlmap_compare_octomap" --octomap-clouds "$work/files/lidar/clouds" \
  --octomap-poses "$work/files/lidar/poses.tum" --octomap-resolution 0.2 --max-range 8 \
  --octomap-voxels "$work/octomap_lidar.txt" > "$work/octomap_lidar.log"
grep -q "octomap replay: 3 frames" "$work/octomap_depth.log"
/usr/bin/python3 - "$work" "$build" <<'PY'
import subprocess, sys
work, build = sys.argv[1], sys.argv[2]
def load(path):
    return {tuple(map(int, l.split())) for l in open(path) if l.strip() and not l.startswith('#')}
def near(v, s):
    return any((v[0] + a, v[1] + b, v[2] + c) in s for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1))
for kind in ('depth', 'lidar'):
    m = load(f'{work}/replay_{kind}/occupied_voxels.txt')
    o = load(f'{work}/octomap_{kind}.txt')
    assert len(m) > 100 and len(o) > 100, (kind, len(m), len(o))
    precision = sum(near(v, o) for v in m) / len(m)
    recall = sum(near(v, m) for v in o) / len(o)
    assert precision > 0.95 and recall > 0.95, (kind, precision, recall)
    print(f'replay from files, {kind}: mlmap {len(m)}, OctoMap {len(o)} voxels; within one cell '
          f'precision {precision:.3f}, recall {recall:.3f}')
    # --agreement gives the same figures for the two lists.
    out = subprocess.run([f'{build}/mlmap_compare_octomap', '--agreement',
                          f'{work}/replay_{kind}/occupied_voxels.txt', f'{work}/octomap_{kind}.txt'],
                         capture_output=True, text=True, check=True).stdout
    assert f'{len(m)} voxels' in out and f'{len(o)} voxels; both {len(m & o)}' in out, out
    assert f'precision {precision:.4f}, recall {recall:.4f}' in out, out
PY
echo "1 2" > "$work/not_a_list.txt"
if "$build/mlmap_compare_octomap" --agreement "$work/not_a_list.txt" "$work/octomap_lidar.txt" \
    > "$work/bad.txt" 2>&1; then
  echo "a malformed voxel list was accepted" >&2; exit 1
fi
grep -q "not_a_list.txt:1: not 'ix iy iz'" "$work/bad.txt"
if "$build/mlmap_compare_octomap" --cases depth:zero --frames 1 > "$work/bad.txt" 2>&1; then
  echo "a bad --cases was accepted" >&2; exit 1
fi
grep -q "not DATASET:RESOLUTION_M" "$work/bad.txt"
if "$build/mlmap_compare_octomap" --cases attic:0.1 --frames 1 > "$work/bad.txt" 2>&1; then
  echo "an unknown dataset was accepted" >&2; exit 1
fi
grep -q "unknown dataset 'attic'" "$work/bad.txt"
echo "smoke run passed"
