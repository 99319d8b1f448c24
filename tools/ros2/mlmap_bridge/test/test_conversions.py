"""conversions.py against slow references and hand-built messages."""

import array
import math
import random
from types import SimpleNamespace

from cloud_helpers import field, FLOAT32, FLOAT64, make_cloud, random_layout, reference_fields
from cloud_helpers import value_for
from mlmap_bridge import conversions as cv
import numpy as np
import pytest


# ---- PointCloud2 decoding -------------------------------------------------------------------

def _random_cloud(rng: random.Random):
    """A cloud with a random layout, size, organisation, endianness and some non-finite points."""
    extra = [('intensity', rng.choice(list(range(1, 9)))), ('rgb', 6)]
    fields, point_step = random_layout(rng, extra)
    height = rng.choice([1, 1, 2, 5])
    width = rng.randint(0, 40)
    points = []
    for _ in range(width * height):
        values = {f.name: value_for(f.datatype, rng) for f in fields}
        roll = rng.random()
        if roll < 0.1:
            values[rng.choice('xyz')] = rng.choice([math.nan, math.inf, -math.inf])
        elif roll < 0.15 and fields[0].datatype in (FLOAT32, FLOAT64):
            values[fields[0].name] = math.nan   # possibly a field that is not read
        points.append(values)
    return make_cloud(points, fields, point_step, width=width, height=height,
                      row_pad=rng.choice([0, 0, 3, 64]), big_endian=rng.random() < 0.4)


@pytest.mark.parametrize('seed', range(200))
def test_fields_equal_a_point_by_point_struct_reference(seed):
    """Random layouts (float32/64, padding, extra fields, big endian, organised, row padding)."""
    rng = random.Random(seed)
    cloud = _random_cloud(rng)
    for names in (('x', 'y', 'z'), ('x', 'y', 'z', 'intensity'), ('intensity',)):
        got = cv.read_cloud_fields(cloud, names)
        expected = np.array(reference_fields(cloud, names), dtype=np.float64)
        expected = expected.reshape(-1, len(names))
        assert got.shape == expected.shape
        assert np.array_equal(got, expected)
    assert np.array_equal(cv.cloud_xyz(cloud), cv.read_cloud_fields(cloud, ('x', 'y', 'z')))


def test_data_may_be_bytes_array_or_list():
    """rclpy gives array.array('B'); other callers bytes or a list of ints."""
    fields = [field('x', 0, FLOAT32), field('y', 4, FLOAT32), field('z', 8, FLOAT32)]
    cloud = make_cloud([{'x': 1.0, 'y': 2.0, 'z': 3.0}, {'x': -1.5, 'y': 0.5, 'z': 8.0}],
                       fields, 12)
    expected = [[1.0, 2.0, 3.0], [-1.5, 0.5, 8.0]]
    for data in (cloud.data, array.array('B', cloud.data), list(cloud.data),
                 bytearray(cloud.data)):
        cloud.data = data
        assert cv.cloud_xyz(cloud).tolist() == expected


def test_empty_cloud_gives_no_points():
    """A cloud of 0 points decodes to an empty (0, 3) array, whatever its other fields say."""
    fields = [field('x', 0, FLOAT32), field('y', 4, FLOAT32), field('z', 8, FLOAT32)]
    cloud = make_cloud([], fields, 12, width=0)
    assert cv.cloud_xyz(cloud).shape == (0, 3)


def _good_cloud():
    fields = [field('x', 0, FLOAT32), field('y', 4, FLOAT32), field('z', 8, FLOAT32)]
    return make_cloud([{'x': 1.0, 'y': 2.0, 'z': 3.0}] * 4, fields, 16, width=2, height=2)


@pytest.mark.parametrize('breakage', [
    lambda c: setattr(c, 'fields', c.fields[:2]),                               # no z
    lambda c: setattr(c, 'fields', c.fields + [field('x', 12, FLOAT32)]),      # two x
    lambda c: setattr(c.fields[0], 'datatype', 9),                             # unknown type
    lambda c: setattr(c.fields[0], 'datatype', 0),
    lambda c: setattr(c.fields[2], 'offset', 13),                              # past point_step
    lambda c: setattr(c.fields[2], 'offset', -1),
    lambda c: setattr(c.fields[1], 'count', 0),
    lambda c: setattr(c, 'data', c.data[:-1]),                                 # short data
    lambda c: setattr(c, 'data', c.data + b'\0'),                              # long data
    lambda c: setattr(c, 'row_step', c.row_step - 1),                          # rows overlap
    lambda c: setattr(c, 'point_step', 0),
    lambda c: setattr(c, 'height', 3),                                         # sizes disagree
    lambda c: setattr(c, 'width', -2),
])
def test_inconsistent_layouts_are_refused(breakage):
    """Every way a layout can disagree with its data raises CloudLayoutError, never garbage."""
    cloud = _good_cloud()
    assert len(cv.cloud_xyz(cloud)) == 4
    breakage(cloud)
    with pytest.raises(cv.CloudLayoutError):
        cv.cloud_xyz(cloud)


# ---- Colours --------------------------------------------------------------------------------

def _reference_scale(value, scale):
    """Linear interpolation between the two stops around value, found by walking the stops."""
    if value <= scale[0][0]:
        return scale[0][1]
    for (p0, c0), (p1, c1) in zip(scale, scale[1:]):
        if value <= p1:
            t = (value - p0) / (p1 - p0)
            return tuple(a + t * (b - a) for a, b in zip(c0, c1))
    return scale[-1][1]


def test_height_colors_follow_the_scale():
    """Colours against a stop-by-stop reference, including below and above the range."""
    rng = np.random.default_rng(1)
    z = rng.uniform(-2.0, 6.0, 500)
    rgba = cv.height_colors(z, 0.0, 4.0, alpha=0.8)
    for value, color in zip(z, rgba):
        assert color[:3] == pytest.approx(_reference_scale(value / 4.0, cv.HEIGHT_SCALE))
        assert color[3] == 0.8
    ends = cv.height_colors(np.array([0.0, 4.0, -9.0, 9.0]), 0.0, 4.0)
    assert ends[0, :3].tolist() == pytest.approx(cv.HEIGHT_SCALE[0][1])
    assert ends[1, :3].tolist() == pytest.approx(cv.HEIGHT_SCALE[-1][1])
    assert ends[2].tolist() == ends[0].tolist() and ends[3].tolist() == ends[1].tolist()


def test_height_range_from_the_data_when_not_given():
    """height_max <= height_min: the cloud's own range; a flat cloud: the middle colour."""
    rgba = cv.height_colors(np.array([2.0, 3.0, 4.0]), 1.0, 1.0)
    assert rgba[0, :3].tolist() == pytest.approx(cv.HEIGHT_SCALE[0][1])
    assert rgba[2, :3].tolist() == pytest.approx(cv.HEIGHT_SCALE[-1][1])
    flat = cv.height_colors(np.array([2.0, 2.0]), 0.0, 0.0)
    assert flat[0, :3].tolist() == pytest.approx(cv.HEIGHT_SCALE[2][1])
    assert cv.height_colors(np.array([]), 0.0, 0.0).shape == (0, 4)


def test_distance_colors_inside_at_and_far_from_obstacles():
    """Purple deep inside, red at the surface, green at and beyond max_distance."""
    d = np.array([-2.0, -5.0, 0.0, 0.5, 2.0, 7.0])
    rgba = cv.distance_colors(d, 2.0)
    assert rgba[0, :3].tolist() == pytest.approx(cv.DISTANCE_SCALE[0][1])
    assert rgba[1].tolist() == rgba[0].tolist()
    assert rgba[2, :3].tolist() == pytest.approx(cv.DISTANCE_SCALE[1][1])
    assert rgba[3, :3].tolist() == pytest.approx(cv.DISTANCE_SCALE[2][1])
    assert rgba[4, :3].tolist() == pytest.approx(cv.DISTANCE_SCALE[-1][1])
    assert rgba[5].tolist() == rgba[4].tolist()
    for value, color in zip(np.linspace(-3, 3, 61), cv.distance_colors(np.linspace(-3, 3, 61), 2)):
        assert color[:3] == pytest.approx(_reference_scale(value / 2.0, cv.DISTANCE_SCALE))
    with pytest.raises(ValueError):
        cv.distance_colors(d, 0.0)


# ---- Voxel edge and thinning ----------------------------------------------------------------

@pytest.mark.parametrize('seed', range(20))
def test_grid_spacing_finds_the_voxel_edge(seed):
    """Float32 voxel centres (i + 0.5) * edge of random grids, anywhere within 100 m."""
    rng = np.random.default_rng(seed)
    edge = rng.uniform(0.02, 0.5)
    base = rng.integers(-int(100 / edge), int(100 / edge), 3)
    index = base + rng.integers(0, 30, (300, 3))
    index[1] = index[0] + np.array([0, 0, 1])   # two touching voxels
    xyz = ((index + 0.5) * edge).astype(np.float32).astype(np.float64)
    assert cv.grid_spacing(xyz) == pytest.approx(edge, abs=2e-5)


def test_grid_spacing_needs_two_distinct_coordinates():
    """One point, or points differing on no axis, tell nothing."""
    assert cv.grid_spacing(np.zeros((0, 3))) is None
    assert cv.grid_spacing(np.array([[0.1, 0.1, 0.1]])) is None
    assert cv.grid_spacing(np.array([[0.1, 0.1, 0.1]] * 3)) is None
    assert cv.grid_spacing(np.array([[0.1, 0.1, 0.1], [0.1, 0.5, 0.1]])) == pytest.approx(0.4)


def test_thin_evenly():
    """All indices when they fit; else at most max_count, spread from first to last."""
    assert cv.thin_evenly(5, 10).tolist() == [0, 1, 2, 3, 4]
    assert cv.thin_evenly(5, 0).tolist() == [0, 1, 2, 3, 4]
    assert cv.thin_evenly(0, 3).tolist() == []
    for count, limit in ((1000, 7), (100001, 100000), (10, 9), (3, 1)):
        idx = cv.thin_evenly(count, limit)
        assert len(idx) <= limit and len(idx) >= min(limit, 2) - 1
        assert np.all(np.diff(idx) > 0) and idx[0] == 0
        if limit > 1:
            assert idx[-1] == count - 1
            gaps = np.diff(idx)
            assert gaps.max() - gaps.min() <= 1


# ---- Status text ----------------------------------------------------------------------------

def _status(**changes):
    values = dict(version=3, uptime_s=75.0, frames_in=120, frames_mapped=110, frames_dropped=4,
                  frames_rejected=1, clouds_malformed=2, clouds_without_pose=3, poses_rejected=0,
                  points_rejected=77, awareness_median_ms=5.84, awareness_p99_ms=7.1,
                  local_global_median_ms=0.17, local_global_p99_ms=0.34, total_median_ms=6.02,
                  total_p99_ms=7.44, esdf_last_ms=4.6, awareness_bytes=15_000_000,
                  local_bytes=631_750, global_bytes=2048, planning_bytes=1_300_000,
                  global_voxels=149, frames_unexpected_frame_id=0,
                  frames_unresolved_frame_id=0, odometry_child_frame_mismatch=0,
                  tf_odom_missing=0, hits_beyond_local_map=0, hits_outside_window=0,
                  hits_to_global_map=0, hits_lost=0)
    values.update(changes)
    return SimpleNamespace(**values)


def test_status_text_reports_frames_timings_and_memory():
    """Every figure of the overlay is taken from the message, with units."""
    text = cv.status_text(_status())
    assert text.splitlines()[0] == 'mlmap up 1:15: 110 frames mapped of 120'
    assert 'dropped 4, rejected 1, without pose 3, malformed 2, poses rejected 0' in text
    assert 'awareness 5.8/7.1' in text and 'local-global 0.2/0.3' in text
    assert 'total 6.0/7.4' in text and 'ESDF 4.6' in text
    assert 'awareness 15.0 MB' in text and 'local 631.8 kB' in text
    assert 'global 2.0 kB (149 voxels)' in text and 'planning 1.3 MB' in text
    assert 'frame checks' not in text, 'only when a frame check counted something'
    checked = cv.status_text(_status(frames_unresolved_frame_id=3, tf_odom_missing=1))
    assert ('frame checks: frame_id unexpected 0, unresolved 3; odometry child frame 0; '
            'odom -> body missing 1') in checked
    assert 'outside the window' not in text, 'only when hits fell outside the window'
    far = cv.status_text(_status(hits_beyond_local_map=500, hits_outside_window=40,
                                 hits_to_global_map=480, hits_lost=2))
    assert far.splitlines()[-1] == ('outside the window: 500 points, 40 hit voxels; 480 hits to '
                                    'the global map (no free space), 2 lost')


def test_status_text_gives_the_mapping_rate_from_the_previous_status():
    """Frames mapped between two statuses over their uptime difference."""
    before = _status(uptime_s=70.0, frames_mapped=60)
    assert '(10.0 Hz)' in cv.status_text(_status(), before)
    assert cv.mapping_rate_hz(_status(), before) == pytest.approx(10.0)
    assert cv.mapping_rate_hz(_status(), None) is None
    assert cv.mapping_rate_hz(_status(), _status()) is None                  # same message
    assert cv.mapping_rate_hz(_status(uptime_s=3.0, frames_mapped=5), _status()) is None


def test_status_of_an_unknown_version_is_not_read():
    """idl/README.md: a reader refuses a layout version it does not know."""
    for old in (1, 2):
        text = cv.status_text(_status(version=old))
        assert f'layout version {old} unknown' in text and 'frames' not in text


def test_formatting():
    """Bytes and durations as people read them."""
    assert [cv.format_bytes(n) for n in (0, 999, 1000, 1_234_567, 2.5e9)] == \
        ['0 B', '999 B', '1.0 kB', '1.2 MB', '2.5 GB']
    assert [cv.format_duration(s) for s in (0, 59.9, 61, 3600, 3725, -4)] == \
        ['0:00', '0:59', '1:01', '1:00:00', '1:02:05', '0:00']


# ---- Rate limiting --------------------------------------------------------------------------

def test_rate_limiter():
    """At most one event per period; 0 Hz lets everything through; a clock jump back passes."""
    limiter = cv.RateLimiter(2.0)
    passed = [t for t in np.arange(0.0, 3.0, 0.1) if limiter.ready(float(t))]
    assert passed == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0, 2.5], abs=1e-9)
    everything = cv.RateLimiter(0.0)
    assert all(everything.ready(0.0) for _ in range(5))
    jumpy = cv.RateLimiter(1.0)
    assert jumpy.ready(10.0) and not jumpy.ready(10.5) and jumpy.ready(3.0)
    with pytest.raises(ValueError):
        cv.RateLimiter(-1.0)


def test_latest_throttle_never_loses_the_last_sample():
    """A burst: the first goes at once, the newest waiting one goes when the period is over."""
    throttle = cv.LatestThrottle(1.0)
    assert throttle.offer('a', 0.0) == 'a'
    assert throttle.offer('b', 0.2) is None
    assert throttle.offer('c', 0.4) is None
    assert throttle.poll(0.9) is None
    assert throttle.poll(1.0) == 'c'          # b was replaced by the newer c
    assert throttle.poll(5.0) is None         # nothing waits any more
    assert throttle.offer('d', 5.1) == 'd'    # quiet for long: goes at once
    assert throttle.offer('e', 5.5) is None
    assert throttle.offer('f', 6.2) == 'f'    # period over: goes at once, e is dropped as stale
    assert throttle.poll(9.0) is None
    unlimited = cv.LatestThrottle(0.0)
    assert [unlimited.offer(i, 0.0) for i in range(3)] == [0, 1, 2]
