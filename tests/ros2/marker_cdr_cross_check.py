"""The bridge's serialised MarkerArray against an independent CDR implementation.

mlmap_bridge/marker_cdr.py writes visualization_msgs/MarkerArray bytes itself (from numpy
arrays); rclpy publishes them as they are, so a layout mistake would reach RViz as garbage.
This writes a set of cube lists (empty, one cube, odd and even counts so every alignment case
occurs, a long frame_id, non-ASCII text, extreme values), has marker_cdr_check.mjs read them
with @foxglove/rosmsg2-serialization and write them again (byte for byte the same), and compares
what it decoded with the arrays that went in.

    /usr/bin/python3 marker_cdr_cross_check.py NPM_DIR
NPM_DIR holds node_modules with the packages of tests/bag/fixtures/package-lock.json (the
ctest fixture mlmap_bag_fixtures installs them in the build tree).
"""

from pathlib import Path
import json
import shutil
import subprocess
import sys
import tempfile

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / 'tools' / 'ros2' / 'mlmap_bridge'))
from mlmap_bridge import marker_cdr  # noqa: E402  (the source tree, no install)


def cases():
    """(name, arguments of cube_list_array) for every layout case worth checking.

    The library's writer sizes a string by its UTF-16 length, so a non-ASCII string is only
    read by it (case "utf8"), not written again byte for byte.
    """
    rng = np.random.default_rng(7)
    out = []
    for count in (0, 1, 2, 3, 1000):
        xyz = rng.uniform(-500.0, 500.0, (count, 3))
        rgba = rng.uniform(0.0, 1.0, (count, 4))
        # Frame names of 1 to 8 characters and a long one: the pose's 8-byte alignment after
        # the strings falls on every case, padded and not.
        for frame in ('m', 'ma', 'map', 'odom', 'uav1/', 'uav1/m', 'uav1/ma', 'uav1/map',
                      'uav1/odom_with_a_long_frame_name'):
            out.append((f'n{count}_{len(frame)}',
                        (1_700_000_000 + count, 123_456_789, frame, 'local_map', xyz, rgba, 0.1)))
    out.append(('extremes', (-1, 4_294_967_295, 'm', 'x',
                             np.array([[1e300, -0.0, 5e-324]]), np.array([[0.0, 1.0, 0.5, 1.0]]),
                             1e-9)))
    out.append(('utf8', (5, 6, 'carte', 'carte_époque_地図', xyz[:3], rgba[:3], 0.2)))
    return out


def check(npm_dir: Path) -> int:
    """Run the cross-check; return the number of failures."""
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        files, expected = [], {}
        for name, args in cases():
            path = Path(tmp) / f'{name}.cdr'
            path.write_bytes(marker_cdr.cube_list_array(*args))
            files.append(str(path))
            expected[str(path)] = args
        script = npm_dir / 'marker_cdr_check.mjs'  # ES modules resolve beside node_modules
        shutil.copyfile(HERE / 'marker_cdr_check.mjs', script)
        output = subprocess.run(['node', str(script)] + files, capture_output=True, text=True,
                                check=True, timeout=120).stdout
    for result in json.loads(output):
        sec, nanosec, frame, ns, xyz, rgba, size = expected[result['file']]
        name = Path(result['file']).stem
        problems = []
        if 'error' in result:
            problems.append(result['error'])
        else:
            if not result['same_bytes'] and name != 'utf8':
                problems.append(f"rewritten as {result['rewritten_length']} bytes, "
                                f"not the same {result['length']}")
            (m,) = result['markers']
            delete = len(xyz) == 0
            want = {'stamp': [sec, nanosec], 'frame_id': frame, 'ns': ns, 'id': 0,
                    'type': 0 if delete else marker_cdr.CUBE_LIST,
                    'action': marker_cdr.DELETE if delete else marker_cdr.ADD,
                    'orientation_w': 1.0, 'strings': [''] * 5}
            problems += [f'{k} {m[k]!r}, expected {v!r}' for k, v in want.items() if m[k] != v]
            if not delete and m['scale'] != [size] * 3:
                problems.append(f"scale {m['scale']}")
            if not np.array_equal(np.array(m['points']).reshape(-1, 3), xyz):
                problems.append('points differ')
            colors = np.asarray(rgba, dtype=np.float32).astype(np.float64)
            if not np.array_equal(np.array(m['colors']).reshape(-1, 4), colors):
                problems.append('colours differ')
        print(f"{'FAIL' if problems else 'ok  '} {name}: {result.get('length')} bytes"
              + (': ' + '; '.join(problems) if problems else ''))
        failures += bool(problems)
    return failures


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    failed = check(Path(sys.argv[1]))
    print(f'{len(cases()) - failed} of {len(cases())} MarkerArrays read alike by '
          '@foxglove/rosmsg2-serialization')
    sys.exit(1 if failed else 0)
