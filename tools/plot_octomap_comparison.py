#!/usr/bin/python3
"""Charts of mlmap_compare_octomap's figures (PNG, matplotlib from Debian).

Usage: tools/plot_octomap_comparison.py RESULTS_DIR [RESULTS_DIR ...] --out DIR

Each RESULTS_DIR holds the compare.json (and the *.voxels.txt lists, if written with --voxels)
of one run of mlmap_compare_octomap. Writes into --out:

- octomap_time.png: time per frame of both mappers, per case (median and p99, log scale),
  with the ratio, and the per-frame series;
- octomap_memory.png: memory over the path of the building walk(s), both mappers;
- octomap_agreement.png: IoU, precision and recall of mlmap against OctoMap, exact and
  within one cell;
- octomap_diff_<case>.png for every voxel list: top and side views coloured
  both / only mlmap / only OctoMap.
"""

import argparse
import glob
import json
import os
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)

MLMAP_COLOUR = '#d95f02'
OCTOMAP_COLOUR = '#1b9e77'


def save(fig, out, name):
    """Write `fig` as out/name and return the path."""
    fig.tight_layout()
    path = os.path.join(out, name)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def load_cases(dirs):
    """Return every case of every compare.json, in order."""
    cases = []
    for d in dirs:
        path = os.path.join(d, 'compare.json')
        try:
            with open(path) as f:
                data = json.load(f)
        except (OSError, ValueError) as e:
            sys.exit(f'{path}: cannot read the figures ({e})')
        if 'cases' not in data:
            sys.exit(f'{path}: no "cases" (not written by mlmap_compare_octomap?)')
        for case in data['cases']:
            case['_dir'] = d
            cases.append(case)
    return cases


def both_ran(case):
    """Tell whether the case ran both mappers."""
    return case['mlmap']['ran'] and case['octomap']['ran']


def plot_time(cases, out):
    """Median / p99 per case and the per-frame series."""
    cases = [c for c in cases if both_ran(c)]
    if not cases:
        return None
    fig, axes = plt.subplots(1 + len(cases), 1, figsize=(9, 3.2 * (1 + len(cases))))
    ax = axes[0]
    xs = range(len(cases))
    width = 0.2
    for k, (who, colour) in enumerate((('mlmap', MLMAP_COLOUR), ('octomap', OCTOMAP_COLOUR))):
        med = [c[who]['time_ms']['median'] for c in cases]
        p99 = [c[who]['time_ms']['p99'] for c in cases]
        ax.bar([x + (2 * k - 1.5) * width for x in xs], med, width, color=colour,
               label=f'{"OctoMap" if who == "octomap" else "mlmap"} median')
        ax.bar([x + (2 * k - 0.5) * width for x in xs], p99, width, color=colour, alpha=0.5,
               label=f'{"OctoMap" if who == "octomap" else "mlmap"} p99')
    for x, c in zip(xs, cases):
        ratio = c['octomap']['time_ms']['median'] / max(c['mlmap']['time_ms']['median'], 1e-9)
        ax.annotate(f'{ratio:.1f}x', (x, c['octomap']['time_ms']['p99']), ha='center',
                    va='bottom', fontsize=9)
    ax.set_yscale('log')
    ax.set_ylim(bottom=0.3 * min(c['mlmap']['time_ms']['median'] for c in cases))
    ax.set_xticks(list(xs))
    ax.set_xticklabels([f'{c["name"]}\n{c["points_per_frame"] / 1000:.0f}k points' for c in cases],
                       fontsize=8)
    ax.set_ylabel('time per frame [ms]')
    ax.set_title('time per frame (label: OctoMap median / mlmap median)')
    ax.legend(fontsize=7, ncol=2)
    for ax, c in zip(axes[1:], cases):
        ax.plot(c['mlmap']['frame_ms'], color=MLMAP_COLOUR, label='mlmap')
        ax.plot(c['octomap']['frame_ms'], color=OCTOMAP_COLOUR, label='OctoMap')
        ax.set_yscale('log')
        ax.set_xlabel('frame')
        ax.set_ylabel('ms')
        ax.set_title(c['name'], fontsize=9)
        ax.legend(fontsize=7)
    return save(fig, out, 'octomap_time.png')


def plot_memory(cases, out):
    """Memory over the path of the building walk(s) (or of any case, if none)."""
    chosen = [c for c in cases if c['dataset'].startswith('building')] or cases
    chosen = [c for c in chosen if c['mlmap']['memory_bytes'] or c['octomap']['memory_bytes']]
    if not chosen:
        return None
    fig, axes = plt.subplots(len(chosen), 1, figsize=(9, 3.6 * len(chosen)), squeeze=False)
    for ax, c in zip(axes[:, 0], chosen):
        path_m = c['path_m']
        use_path = any(p > 0 for p in path_m)
        series = (('mlmap', MLMAP_COLOUR, 'mlmap (engine accounting, all layers)'),
                  ('octomap', OCTOMAP_COLOUR, 'OctoMap (OcTree::memoryUsage)'))
        for who, colour, label in series:
            mem = c[who]['memory_bytes']
            if not mem:
                continue
            xs = path_m[:len(mem)] if use_path else range(len(mem))
            ax.plot(xs, [m / 1e6 for m in mem], color=colour, label=label)
        layers = c['mlmap'].get('map_memory_bytes', [])
        if layers:
            xs = path_m[:len(layers)] if use_path else range(len(layers))
            ax.plot(xs, [m / 1e6 for m in layers], color=MLMAP_COLOUR, linestyle='--',
                    label='mlmap map layers alone (local + global)')
        ax.set_xlabel('path [m]' if use_path else 'frame')
        ax.set_ylabel('memory [MB]')
        ax.set_title(f'{c["name"]}: memory over the walk', fontsize=10)
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=8)
    return save(fig, out, 'octomap_memory.png')


def plot_agreement(cases, out):
    """IoU, precision and recall, exact and within one cell."""
    cases = [c for c in cases if both_ran(c)]
    if not cases:
        return None
    keys = [('iou', 'IoU'), ('precision', 'precision'), ('recall', 'recall'),
            ('iou_1', 'IoU (1 cell)'), ('precision_1', 'precision (1 cell)'),
            ('recall_1', 'recall (1 cell)')]
    fig, ax = plt.subplots(figsize=(9, 4))
    width = 0.8 / len(keys)
    colours = ['#1f78b4', '#33a02c', '#e31a1c', '#a6cee3', '#b2df8a', '#fb9a99']
    for k, ((key, label), colour) in enumerate(zip(keys, colours)):
        ax.bar([i + (k - len(keys) / 2 + 0.5) * width for i in range(len(cases))],
               [c['agreement'][key] for c in cases], width, label=label, color=colour)
    ax.axhline(0.8, color='grey', linestyle='--', linewidth=0.8)
    ax.set_xticks(range(len(cases)))
    ax.set_xticklabels([c['name'] for c in cases], fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel('mlmap against OctoMap')
    ax.set_title('occupied-voxel agreement (dashed: IoU 0.8)')
    ax.legend(fontsize=7, ncol=3, loc='lower right')
    return save(fig, out, 'octomap_agreement.png')


def read_voxels(path):
    """Return (resolution, [(x, y, z, where)]) from a *.voxels.txt list."""
    rows = []
    resolution = None
    with open(path) as f:
        for n, line in enumerate(f, 1):
            if line.startswith('#'):
                if 'floor(coordinate / ' in line:
                    resolution = float(line.split('floor(coordinate / ')[1].split(')')[0])
                continue
            parts = line.split()
            if len(parts) != 4:
                sys.exit(f'{path}:{n}: expected "ix iy iz where", got {line.strip()!r}')
            rows.append(tuple(int(p) for p in parts))
    if resolution is None:
        sys.exit(f'{path}: no resolution in the header')
    return resolution, rows


def plot_diff(path, out, frame_hint):
    """Top and side views of where the occupied sets differ."""
    resolution, rows = read_voxels(path)
    name = os.path.basename(path)[:-len('.voxels.txt')]
    # Marker area shrinks with the number of voxels so that dense maps stay readable.
    base = max(1.0, min(12.0, 4000.0 / max(len(rows), 1) ** 0.75))
    groups = {3: ('both', '#bbbbbb', base), 1: ('only mlmap', MLMAP_COLOUR, 2 * base),
              2: ('only OctoMap', OCTOMAP_COLOUR, 2 * base)}
    # The RealSense world is the first camera's optical frame (x right, y down, z forward):
    # "top" looks along +y (x across, z up the page), "side" along -x (z across, -y up).
    optical = frame_hint == 'optical'
    views = ([('top (x, z)', 0, 2, 1), ('side (z, -y)', 2, 1, -1)] if optical
             else [('top (x, y)', 0, 1, 1), ('side (x, z)', 0, 2, 1)])
    fig, axes = plt.subplots(1, 2, figsize=(13, 6))
    for ax, (title, a, b, sign) in zip(axes, views):
        for where in (3, 1, 2):
            label, colour, size = groups[where]
            pts = [r for r in rows if r[3] == where]
            if not pts:
                continue
            ax.scatter([(p[a] + 0.5) * resolution for p in pts],
                       [sign * (p[b] + 0.5) * resolution for p in pts],
                       s=size, c=colour, marker='s', linewidths=0,
                       label=f'{label} ({len(pts)})')
        ax.set_aspect('equal')
        ax.set_title(title)
        ax.set_xlabel('m')
        ax.legend(fontsize=8, markerscale=3)
    counts = {w: sum(1 for r in rows if r[3] == w) for w in (1, 2, 3)}
    fig.suptitle(f'{name}: occupied voxels at {resolution} m, both {counts[3]}, '
                 f'only mlmap {counts[1]}, only OctoMap {counts[2]}')
    return save(fig, out, f'octomap_diff_{name}.png')


def main():
    """Read the figures and write the charts."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('results', nargs='+',
                        help='folders written by mlmap_compare_octomap --out')
    parser.add_argument('--out', required=True, help='folder for the PNG charts')
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    cases = load_cases(args.results)
    written = [plot_time(cases, args.out), plot_memory(cases, args.out),
               plot_agreement(cases, args.out)]
    for d in args.results:
        for path in sorted(glob.glob(os.path.join(d, '*.voxels.txt'))):
            hint = 'optical' if os.path.basename(path).startswith('realsense') else 'world'
            written.append(plot_diff(path, args.out, hint))
    for path in written:
        if path:
            print(f'wrote {path}')


if __name__ == '__main__':
    main()
