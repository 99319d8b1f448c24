"""What the bridge computes, on plain message fields with numpy only (no rclpy import).

The bridge node (bridge_node.py) only wires topics; everything it shows is computed here, so
it is unit-tested without ROS (test/test_conversions.py):

- sensor_msgs/PointCloud2 fields -> an (N, k) array of named fields, honouring offsets,
  datatypes, endianness, point_step and row_step, and skipping points with a NaN/Inf field;
- points -> cube-list colours by height, ESDF distances -> colours by distance;
- the voxel edge of a cloud of voxel centres, and an even thinning of large clouds;
- mlmap_msgs/Status -> the text the overlay shows;
- a rate limiter, so a layer is converted at most so often.

Arguments are "message-like": any object with the ROS field names (an rclpy message, or a
SimpleNamespace in tests).
"""

from typing import Optional, Sequence, Tuple

import numpy as np

# sensor_msgs/PointField datatypes -> numpy type codes (without byte order).
POINT_FIELD_TYPES = {1: 'i1', 2: 'u1', 3: 'i2', 4: 'u2', 5: 'i4', 6: 'u4', 7: 'f4', 8: 'f8'}

# The mlmap_msgs layout version this bridge reads (idl/README.md: refuse unknown versions).
SUPPORTED_STATUS_VERSION = 3

# Colour scales: (position in [0, 1] or [-1, 1], (r, g, b)), linearly interpolated.
HEIGHT_SCALE = (
    (0.00, (0.19, 0.07, 0.55)),   # low: violet
    (0.25, (0.12, 0.47, 0.95)),   # blue
    (0.50, (0.16, 0.80, 0.45)),   # green
    (0.75, (0.98, 0.82, 0.15)),   # yellow
    (1.00, (0.85, 0.16, 0.10)),   # high: red
)
DISTANCE_SCALE = (
    (-1.0, (0.35, 0.00, 0.45)),   # deep inside an obstacle: purple
    (0.00, (0.90, 0.05, 0.05)),   # at the obstacle surface: red
    (0.25, (1.00, 0.55, 0.00)),   # close: orange
    (0.50, (0.95, 0.90, 0.20)),   # yellow
    (1.00, (0.10, 0.65, 0.35)),   # at or beyond the clamp distance: green (safe)
)


class CloudLayoutError(ValueError):
    """A PointCloud2 whose sizes, steps or fields do not describe its data."""


def _data_bytes(data) -> np.ndarray:
    """View a message's uint8[] data (bytes, array.array('B'), list) as a numpy uint8 array."""
    try:
        return np.frombuffer(memoryview(data), dtype=np.uint8)
    except TypeError:
        return np.asarray(data, dtype=np.uint8)


def read_cloud_fields(cloud, names: Sequence[str]) -> np.ndarray:
    """Return the named fields of every point of a PointCloud2 as float64, shape (N, len(names)).

    Points where any of the named fields is NaN or infinite are skipped. The first element of
    each field is read (PointField.count > 1 is accepted). Raises CloudLayoutError when a field is
    missing, duplicated, of an unknown datatype or outside point_step, or when the sizes and
    steps disagree with len(data) (which must be row_step * height, as sensor_msgs defines).
    """
    height, width = int(cloud.height), int(cloud.width)
    point_step, row_step = int(cloud.point_step), int(cloud.row_step)
    data = _data_bytes(cloud.data)
    if height < 0 or width < 0:
        raise CloudLayoutError(f'negative size {width} x {height}')
    if height * width == 0:
        return np.empty((0, len(names)), dtype=np.float64)
    if point_step <= 0 or row_step < width * point_step:
        raise CloudLayoutError(
            f'point_step {point_step} and row_step {row_step} cannot hold {width} points a row')
    if data.size != row_step * height:
        raise CloudLayoutError(f'{data.size} data bytes, expected row_step * height = '
                               f'{row_step * height}')
    order = '>' if cloud.is_bigendian else '<'
    formats, offsets = [], []
    for name in names:
        matching = [f for f in cloud.fields if f.name == name]
        if len(matching) != 1:
            raise CloudLayoutError(f'{len(matching)} fields named {name!r}')
        field = matching[0]
        code = POINT_FIELD_TYPES.get(int(field.datatype))
        if code is None:
            raise CloudLayoutError(f'field {name!r} has unknown datatype {field.datatype}')
        if int(field.count) < 1:
            raise CloudLayoutError(f'field {name!r} has count {field.count}')
        fmt = np.dtype(order + code)
        if int(field.offset) < 0 or int(field.offset) + fmt.itemsize > point_step:
            raise CloudLayoutError(f'field {name!r} at offset {field.offset} does not fit in '
                                   f'point_step {point_step}')
        formats.append(fmt)
        offsets.append(int(field.offset))
    layout = np.dtype({'names': [f'f{i}' for i in range(len(names))], 'formats': formats,
                       'offsets': offsets, 'itemsize': point_step})
    rows = data.reshape(height, row_step)[:, :width * point_step]
    points = np.ascontiguousarray(rows).reshape(-1).view(layout)
    values = np.stack([points[f'f{i}'].astype(np.float64) for i in range(len(names))], axis=1)
    return values[np.all(np.isfinite(values), axis=1)]


def cloud_xyz(cloud) -> np.ndarray:
    """Return the finite x, y, z of a PointCloud2 as float64, shape (N, 3)."""
    return read_cloud_fields(cloud, ('x', 'y', 'z'))


def scale_colors(values: np.ndarray, scale: Sequence[Tuple[float, Tuple[float, float, float]]],
                 alpha: float = 1.0) -> np.ndarray:
    """Map values (already in the scale's coordinates) to RGBA in [0, 1], shape (N, 4).

    Values outside the scale take the colour of its nearer end.
    """
    positions = np.array([p for p, _ in scale], dtype=np.float64)
    colors = np.array([c for _, c in scale], dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    rgba = np.empty((values.size, 4), dtype=np.float64)
    for channel in range(3):
        rgba[:, channel] = np.interp(values, positions, colors[:, channel])
    rgba[:, 3] = alpha
    return rgba


def height_colors(z: np.ndarray, z_min: float, z_max: float, alpha: float = 1.0) -> np.ndarray:
    """Colour points by height: z_min (or below) violet ... z_max (or above) red.

    When z_max <= z_min the range is taken from the data itself; a flat cloud gets the middle
    colour.
    """
    z = np.asarray(z, dtype=np.float64)
    if z_max <= z_min and z.size:
        z_min, z_max = float(z.min()), float(z.max())
    span = z_max - z_min
    t = np.full(z.shape, 0.5) if span <= 0 else (z - z_min) / span
    return scale_colors(t, HEIGHT_SCALE, alpha)


def packed_rgb_colors(cloud, alpha: float = 1.0) -> Tuple[np.ndarray, np.ndarray]:
    """Return the finite x, y, z of a PointCloud2 and the colours of its `rgb` field.

    `rgb` holds 0x00RRGGBB: packed in a float32 as PCL and RViz read it (mlmap_fleet's fleet
    map: the colour of the first vehicle that saw the voxel), or as an unsigned integer.
    Returns xyz (float64, shape (N, 3)) and rgba in [0, 1] (shape (N, 4)).
    """
    rgb_field = [f for f in cloud.fields if f.name == 'rgb']
    fields = read_cloud_fields(cloud, ('x', 'y', 'z', 'rgb'))
    if rgb_field and int(rgb_field[0].datatype) == 7:  # FLOAT32: the bits are the colour
        bits = fields[:, 3].astype(np.float32).view(np.uint32)
    else:
        bits = fields[:, 3].astype(np.uint32)
    rgba = np.empty((len(bits), 4), dtype=np.float64)
    for channel, shift in enumerate((16, 8, 0)):
        rgba[:, channel] = ((bits >> shift) & 0xff) / 255.0
    rgba[:, 3] = alpha
    return fields[:, :3], rgba


def distance_colors(distance_m: np.ndarray, max_distance_m: float,
                    alpha: float = 1.0) -> np.ndarray:
    """Colour signed distances: purple inside obstacles, red at them, green at max_distance_m."""
    if max_distance_m <= 0:
        raise ValueError(f'max_distance_m must be positive, got {max_distance_m}')
    return scale_colors(np.asarray(distance_m, dtype=np.float64) / max_distance_m,
                        DISTANCE_SCALE, alpha)


def grid_spacing(xyz: np.ndarray, decimals: int = 6) -> Optional[float]:
    """Return the smallest gap between distinct coordinates along any axis, or None.

    For voxel centres on a regular grid this is the voxel edge as soon as two voxels touch
    along an axis (otherwise a multiple of it). Coordinates are rounded to `decimals` first so
    float32 centres of the same voxel layer compare equal.
    """
    best = None
    for axis in range(xyz.shape[1] if xyz.ndim == 2 else 0):
        values = np.unique(np.round(xyz[:, axis], decimals))
        if values.size < 2:
            continue
        gap = float(np.min(np.diff(values)))
        best = gap if best is None else min(best, gap)
    return best


def thin_evenly(count: int, max_count: int) -> np.ndarray:
    """Pick at most max_count of count indices, spread evenly (all of them if they fit)."""
    if max_count <= 0 or count <= max_count:
        return np.arange(count)
    return np.unique(np.linspace(0, count - 1, max_count).round().astype(np.int64))


def format_bytes(count: float) -> str:
    """Format a byte count for people: 512 B, 12.3 kB, 4.5 MB, 1.2 GB."""
    for unit, size in (('GB', 1e9), ('MB', 1e6), ('kB', 1e3)):
        if count >= size:
            return f'{count / size:.1f} {unit}'
    return f'{int(count)} B'


def format_duration(seconds: float) -> str:
    """Format an uptime as h:mm:ss (or m:ss under an hour)."""
    total = int(max(seconds, 0.0))
    hours, rest = divmod(total, 3600)
    minutes, secs = divmod(rest, 60)
    return f'{hours}:{minutes:02d}:{secs:02d}' if hours else f'{minutes}:{secs:02d}'


def mapping_rate_hz(status, previous) -> Optional[float]:
    """Frames mapped per second between two Status messages of the same run, or None."""
    if previous is None:
        return None
    dt = float(status.uptime_s) - float(previous.uptime_s)
    frames = int(status.frames_mapped) - int(previous.frames_mapped)
    if dt <= 0 or frames < 0:
        return None  # same message, or the node restarted in between
    return frames / dt


def status_text(status, previous=None) -> str:
    """Write the overlay text of a Status: frames and rate, rejections, timings, memory.

    `previous` (the Status before, or None) gives the mapping rate. A layout version this
    bridge does not know is reported instead of being read.
    """
    version = int(status.version)
    if version != SUPPORTED_STATUS_VERSION:
        return (f'mlmap status: layout version {version} unknown '
                f'(this bridge reads version {SUPPORTED_STATUS_VERSION})')
    rate = mapping_rate_hz(status, previous)
    rate_text = f' ({rate:.1f} Hz)' if rate is not None else ''
    return '\n'.join([
        f'mlmap up {format_duration(status.uptime_s)}: {status.frames_mapped} frames mapped'
        f'{rate_text} of {status.frames_in}',
        f'dropped {status.frames_dropped}, rejected {status.frames_rejected}, '
        f'without pose {status.clouds_without_pose}, malformed {status.clouds_malformed}, '
        f'poses rejected {status.poses_rejected}',
        f'ms median/p99: awareness {status.awareness_median_ms:.1f}/'
        f'{status.awareness_p99_ms:.1f}, local-global {status.local_global_median_ms:.1f}/'
        f'{status.local_global_p99_ms:.1f}, total {status.total_median_ms:.1f}/'
        f'{status.total_p99_ms:.1f}, ESDF {status.esdf_last_ms:.1f}',
        f'memory: awareness {format_bytes(status.awareness_bytes)}, '
        f'local {format_bytes(status.local_bytes)}, global {format_bytes(status.global_bytes)} '
        f'({status.global_voxels} voxels), planning {format_bytes(status.planning_bytes)}',
    ] + _frame_check_lines(status) + _window_lines(status))


def _frame_check_lines(status) -> list:
    """Return a line of the frame checks' counters when one is not zero, else none."""
    counts = (status.frames_unexpected_frame_id, status.frames_unresolved_frame_id,
              status.odometry_child_frame_mismatch, status.tf_odom_missing)
    if not any(int(n) for n in counts):
        return []
    return [f'frame checks: frame_id unexpected {counts[0]}, unresolved {counts[1]}; '
            f'odometry child frame {counts[2]}; odom -> body missing {counts[3]}']


def _window_lines(status) -> list:
    """Return a line on the hits outside the local window when there were any, else none."""
    if not int(status.hits_beyond_local_map) + int(status.hits_outside_window):
        return []
    return [f'outside the window: {status.hits_beyond_local_map} points, '
            f'{status.hits_outside_window} hit voxels; {status.hits_to_global_map} hits to the '
            f'global map (no free space), {status.hits_lost} lost']


class RateLimiter:
    """Lets an event through at most max_rate_hz times per second (0: every time)."""

    def __init__(self, max_rate_hz: float):
        """Create a limiter; max_rate_hz must be >= 0."""
        if max_rate_hz < 0:
            raise ValueError(f'max_rate_hz must be >= 0, got {max_rate_hz}')
        self._period_s = 1.0 / max_rate_hz if max_rate_hz > 0 else 0.0
        self._last_s: Optional[float] = None

    def ready(self, now_s: float) -> bool:
        """Return True (and count the event) if a period has passed since the last one.

        A clock that went backwards (now_s before the last event) lets the event through.
        """
        if (self._last_s is None or now_s - self._last_s >= self._period_s
                or now_s < self._last_s):
            self._last_s = now_s
            return True
        return False


class LatestThrottle:
    """Passes on at most max_rate_hz samples per second without ever losing the newest one.

    offer() returns the sample when it may go now; otherwise the sample waits (replacing any
    older waiting one) until poll(), called periodically, finds the period over. So the last
    sample of a burst, such as the final global map, is always shown, and stale ones never.
    """

    def __init__(self, max_rate_hz: float):
        """Create a throttle; max_rate_hz must be >= 0 (0: every sample goes at once)."""
        self._limiter = RateLimiter(max_rate_hz)
        self._waiting = None

    def offer(self, sample, now_s: float):
        """Return sample if it may go now, else keep it as the waiting one and return None."""
        if self._limiter.ready(now_s):
            self._waiting = None
            return sample
        self._waiting = sample
        return None

    def poll(self, now_s: float):
        """Return the waiting sample once its period is over (and forget it), else None."""
        if self._waiting is None or not self._limiter.ready(now_s):
            return None
        sample, self._waiting = self._waiting, None
        return sample
