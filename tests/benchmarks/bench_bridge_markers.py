"""How many voxels per second the bridge turns into RViz markers (no ROS needed).

Times mlmap_bridge's cloud_layer_markers, the whole conversion of one received PointCloud2
(decoding the cloud, the cube edge, colours, serialising the MarkerArray), on clouds of voxel
centres as mlmap_node writes them, for the height-coloured and the distance-coloured layers.
Prints the median and p99 per cloud and the voxels per second of the median, and the same for
building the markers as one Python object per point and colour (what rclpy's generated
message classes need; here with small slotted classes, cheaper than rclpy's), for comparison.

    /usr/bin/python3 tests/benchmarks/bench_bridge_markers.py [--sizes 10000 100000] [--repeats 20]
"""

import argparse
from pathlib import Path
import sys
import time
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / 'tools' / 'ros2' / 'mlmap_bridge'))
from mlmap_bridge.conversions import cloud_xyz, height_colors  # noqa: E402
from mlmap_bridge.markers import cloud_layer_markers  # noqa: E402
from mlmap_bridge.parameters import CLOUD_LAYERS, defaults  # noqa: E402


class Point:
    """A stand-in for geometry_msgs/Point: one object per point."""

    __slots__ = ('x', 'y', 'z')

    def __init__(self, x, y, z):
        """Set the coordinates."""
        self.x, self.y, self.z = x, y, z


class Color:
    """A stand-in for std_msgs/ColorRGBA."""

    __slots__ = ('r', 'g', 'b', 'a')

    def __init__(self, r, g, b, a):
        """Set the channels."""
        self.r, self.g, self.b, self.a = r, g, b, a


def voxel_cloud(count: int, intensity: bool, edge: float = 0.1) -> SimpleNamespace:
    """Make a float32 cloud of count voxel centres (x, y, z[, intensity]) in a 40 m box."""
    rng = np.random.default_rng(count)
    cells = np.unique(rng.integers(-200, 200, (count * 2, 3)), axis=0)[:count]
    xyz = ((cells + 0.5) * edge).astype(np.float32)
    columns = [xyz] + ([rng.uniform(-0.5, 2.0, (len(xyz), 1)).astype(np.float32)]
                       if intensity else [])
    data = np.ascontiguousarray(np.hstack(columns))
    names = ('x', 'y', 'z', 'intensity')[:data.shape[1]]
    fields = [SimpleNamespace(name=n, offset=4 * i, datatype=7, count=1)
              for i, n in enumerate(names)]
    header = SimpleNamespace(stamp=SimpleNamespace(sec=1, nanosec=2), frame_id='map')
    return SimpleNamespace(header=header, height=1, width=len(data), fields=fields,
                           is_bigendian=False, point_step=4 * len(names),
                           row_step=4 * len(names) * len(data), data=data.tobytes(),
                           is_dense=True)


def per_object_markers(cloud, settings):
    """Build the height layer as one Python object per point and colour (the old way)."""
    xyz = cloud_xyz(cloud)
    rgba = height_colors(xyz[:, 2], settings['height_min_m'], settings['height_max_m'])
    points = [Point(x, y, z) for x, y, z in xyz.tolist()]
    colors = [Color(r, g, b, a) for r, g, b, a in rgba.tolist()]
    return points, colors


def timed(function, repeats: int):
    """Return the median and p99 [s] of repeats calls."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), float(np.percentile(times, 99))


def main() -> None:
    """Time each layer kind and size; print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--sizes', type=int, nargs='+', default=[10_000, 100_000, 500_000])
    parser.add_argument('--repeats', type=int, default=20)
    args = parser.parse_args()
    layers = {layer.name: layer for layer in CLOUD_LAYERS}
    settings = dict(defaults(), max_cubes=10**9)  # no thinning: every voxel converted
    print('| conversion | voxels | median / p99 [ms] | voxels/s (median) |')
    print('|---|---|---|---|')
    for size in args.sizes:
        runs = (
            ('local_map (height), serialised', layers['local_map'], False),
            ('esdf_slice (distance), serialised', layers['esdf_slice'], True),
        )
        for name, layer, intensity in runs:
            cloud = voxel_cloud(size, intensity)
            median, p99 = timed(lambda: cloud_layer_markers(layer, cloud, settings),
                                args.repeats)
            print(f'| {name} | {cloud.width:,} | {median * 1e3:.1f} / {p99 * 1e3:.1f} | '
                  f'{cloud.width / median / 1e6:.1f} M |', flush=True)
        cloud = voxel_cloud(size, False)
        median, p99 = timed(lambda: per_object_markers(cloud, settings), args.repeats)
        print(f'| height, one Python object per point (old way) | {cloud.width:,} | '
              f'{median * 1e3:.1f} / {p99 * 1e3:.1f} | {cloud.width / median / 1e6:.2f} M |',
              flush=True)


if __name__ == '__main__':
    main()
