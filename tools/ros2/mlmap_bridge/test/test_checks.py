"""checks.py: the integration checker accepts what mlmap_node and the bridge publish, and
refuses each kind of broken sample."""

import copy
import math
from types import SimpleNamespace

from cloud_helpers import field, FLOAT32, FLOAT64, make_cloud
import fake_msgs
from mlmap_bridge import checks as ck
from mlmap_bridge import markers as mk
from mlmap_bridge.conversions import status_text
from mlmap_bridge.parameters import CLOUD_LAYERS, defaults
from marker_reader import read_marker_array
import numpy as np
import pytest

FRAMES = ck.Frames()
TYPES = mk.MessageTypes(Marker=fake_msgs.Marker, MarkerArray=fake_msgs.MarkerArray,
                        Header=fake_msgs.Header)
XYZ = [field('x', 0, FLOAT32), field('y', 4, FLOAT32), field('z', 8, FLOAT32)]
XYZI = XYZ + [field('intensity', 12, FLOAT32)]


def occupied_cloud(edge=0.2, offset_cells=(0, 0, 0), count=60, seed=3, far=0.0):
    """Float32 voxel centres as mlmap_node writes them (x, y, z float32 at 0, 4, 8)."""
    rng = np.random.default_rng(seed)
    index = rng.integers(-30, 30, (count, 3)) + np.array(offset_cells)
    index[1] = index[0] + [0, 1, 0]
    centres = ((index + 0.5) * edge + far).astype(np.float32)
    return make_cloud([dict(zip('xyz', map(float, c))) for c in centres], XYZ, 12)


def esdf_slice(edge=0.2, z_layer=7, distances=(0.4, -0.2, 1.0, 2.0)):
    """One voxel layer of centres with a distance each, as esdfSliceCloud writes it."""
    points = []
    for i, d in enumerate(distances * 5):
        x, y = (i % 5 + 0.5) * edge, (i // 5 + 0.5) * edge
        points.append({'x': x, 'y': y, 'z': (z_layer + 0.5) * edge, 'intensity': d})
    return make_cloud(points, XYZI, 16)


def grid(data=(-1, 0, 100, 0, 0, -1), width=3, height=2, resolution=0.2, w=1.0):
    """A nav_msgs/OccupancyGrid-like object."""
    orientation = SimpleNamespace(x=0.0, y=0.0, z=0.0, w=w)
    info = SimpleNamespace(resolution=resolution, width=width, height=height,
                           origin=SimpleNamespace(orientation=orientation))
    return SimpleNamespace(header=fake_msgs.Header(frame_id='map'), info=info, data=list(data))


def voxel_block(values=None, **changes):
    """A mlmap_msgs/VoxelBlock-like object: 2 x 3 x 4 ESDF with unknown voxels."""
    if values is None:
        values = [math.nan if i % 5 == 0 else (i - 8) * 0.1 for i in range(24)]
    msg = SimpleNamespace(header=fake_msgs.Header(frame_id='map'), version=1, layer='esdf',
                          resolution=0.2, size_x=2, size_y=3, size_z=4, max_value=2.0,
                          values=values)
    for name, value in changes.items():
        setattr(msg, name, value)
    return msg


def status(**changes):
    """A mlmap_msgs/Status-like object of a node that has mapped frames."""
    values = dict(header=fake_msgs.Header(frame_id='map'), version=3, uptime_s=12.5,
                  frames_in=40, frames_mapped=38, frames_dropped=1, frames_rejected=1,
                  clouds_malformed=0, clouds_without_pose=0, poses_rejected=0,
                  points_rejected=3, awareness_median_ms=5.0, awareness_p99_ms=7.0,
                  local_global_median_ms=0.2, local_global_p99_ms=0.3, total_median_ms=5.2,
                  total_p99_ms=7.3, esdf_last_ms=4.0, awareness_bytes=1000, local_bytes=600000,
                  global_bytes=10, planning_bytes=3000, global_voxels=2,
                  frames_unexpected_frame_id=0, frames_unresolved_frame_id=0,
                  odometry_child_frame_mismatch=0, tf_odom_missing=0, hits_beyond_local_map=0,
                  hits_outside_window=0, hits_to_global_map=0, hits_lost=0)
    values.update(changes)
    return SimpleNamespace(**values)


def transform(parent, child, q=(0.0, 0.0, 0.0, 1.0), t=(1.0, 2.0, 1.5)):
    """A geometry_msgs/TransformStamped-like object."""
    return SimpleNamespace(
        header=fake_msgs.Header(frame_id=parent), child_frame_id=child,
        transform=SimpleNamespace(translation=SimpleNamespace(x=t[0], y=t[1], z=t[2]),
                                  rotation=SimpleNamespace(x=q[0], y=q[1], z=q[2], w=q[3])))


def tf(*transforms):
    """A tf2_msgs/TFMessage-like object."""
    return SimpleNamespace(transforms=list(transforms))


# ---- mlmap_node's layers --------------------------------------------------------------------

@pytest.mark.parametrize('edge', [0.05, 0.1, 0.2, 0.35])
@pytest.mark.parametrize('far', [0.0, 250.0])
def test_occupied_voxel_clouds_pass(edge, far):
    """Voxel centres near and far from the origin, at several resolutions."""
    far_cells = round(far / edge) * edge  # keep the grid aligned at the origin
    assert ck.check_occupied_cloud(occupied_cloud(edge=edge, far=far_cells), FRAMES) == []


def test_occupied_cloud_defects_are_reported():
    """Wrong frame, empty, NaN, off the grid, float64 or far-away coordinates."""
    def problems_of(cloud):
        return ck.check_occupied_cloud(cloud, FRAMES)

    wrong_frame = occupied_cloud()
    wrong_frame.header = fake_msgs.Header(frame_id='odom')
    assert 'frame_id' in problems_of(wrong_frame)[0]
    assert problems_of(make_cloud([], XYZ, 12, width=0)) == ['no points']
    with_nan = make_cloud([{'x': 0.1, 'y': 0.1, 'z': 0.1}, {'x': math.nan, 'y': 0.1, 'z': 0.1}],
                          XYZ, 12)
    assert 'not finite' in problems_of(with_nan)[0]
    shifted = occupied_cloud(far=0.07)   # centres off (i + 0.5) * edge
    assert 'not voxel centres' in problems_of(shifted)[0]
    as_float64 = make_cloud([{'x': 0.1, 'y': 0.1, 'z': 0.1}],
                            [field('x', 0, FLOAT64), field('y', 8, FLOAT64),
                             field('z', 16, FLOAT64)], 24)
    assert 'not float32' in problems_of(as_float64)[0]
    huge = make_cloud([{'x': 0.1, 'y': 0.1, 'z': 0.1}, {'x': 3e5 + 0.1, 'y': 0.1, 'z': 0.1}],
                      XYZ, 12)
    assert any('coordinates up to' in p for p in problems_of(huge))
    broken = occupied_cloud()
    broken.data = broken.data[:-1]
    assert 'undecodable' in problems_of(broken)[0]


def test_awareness_cells_need_not_lie_on_a_cartesian_grid():
    """Cylindrical cell centres pass the awareness check, not the voxel-layer one."""
    rng = np.random.default_rng(0)
    points = [{'x': float(r * math.cos(p)), 'y': float(r * math.sin(p)), 'z': 1.1}
              for r, p in zip(rng.uniform(0.5, 9.0, 40), rng.uniform(0.0, 6.28, 40))]
    cloud = make_cloud(points, XYZ, 12)
    assert ck.check_awareness_cloud(cloud, FRAMES) == []
    assert ck.check_occupied_cloud(cloud, FRAMES) != []


def test_esdf_slice():
    """One layer with finite distances and some free space passes; defects do not."""
    assert ck.check_esdf_slice(esdf_slice(), FRAMES) == []
    two_layers = esdf_slice()
    extra = esdf_slice(z_layer=8)
    two_layers.data += extra.data
    two_layers.width += extra.width
    two_layers.row_step += extra.row_step
    assert any('one layer' in p for p in ck.check_esdf_slice(two_layers, FRAMES))
    assert any('no positive distance' in p
               for p in ck.check_esdf_slice(esdf_slice(distances=(-0.2, -0.4)), FRAMES))
    no_intensity = occupied_cloud()
    assert 'undecodable' in ck.check_esdf_slice(no_intensity, FRAMES)[0]
    assert ck.check_esdf_slice(make_cloud([], XYZI, 16, width=0), FRAMES) == ['no points']


def test_grid():
    """Sizes, cell values, observed cells and the origin's orientation."""
    assert ck.check_grid(grid(), FRAMES) == []
    assert ck.check_grid(grid(width=4), FRAMES)
    assert ck.check_grid(grid(data=(-1, 0, 101, 0, 0, 0)), FRAMES)
    assert ck.check_grid(grid(data=(-1, -2, 0, 0, 0, 0)), FRAMES)
    assert ck.check_grid(grid(data=(-1,) * 6), FRAMES) == ['every cell unknown']
    assert ck.check_grid(grid(resolution=0.0), FRAMES)
    assert ck.check_grid(grid(w=0.0), FRAMES)
    assert ck.check_grid(grid(data=(), width=0, height=0), FRAMES)


def test_voxel_block():
    """Version, layer, sizes against values, values within +-max_value, some free space."""
    assert ck.check_voxel_block(voxel_block(), FRAMES) == []
    assert ck.check_voxel_block(voxel_block(version=2), FRAMES) == [
        'layout version 2, expected 1']
    assert ck.check_voxel_block(voxel_block(layer='tsdf'), FRAMES)
    assert ck.check_voxel_block(voxel_block(size_z=5), FRAMES)
    assert ck.check_voxel_block(voxel_block(resolution=0.0), FRAMES)
    assert ck.check_voxel_block(voxel_block(values=[math.nan] * 24), FRAMES)[-1] == \
        'every voxel unknown (NaN)'
    too_far = voxel_block()
    too_far.values = list(too_far.values[:-1]) + [2.5]
    assert any('beyond' in p for p in ck.check_voxel_block(too_far, FRAMES))
    infinite = voxel_block()
    infinite.values = list(infinite.values[:-1]) + [math.inf]
    assert any('beyond' in p for p in ck.check_voxel_block(infinite, FRAMES))
    inside_only = voxel_block(values=[-0.2] * 24)
    assert ck.check_voxel_block(inside_only, FRAMES) == ['no positive distance: no free space']


def test_status():
    """A node that mapped frames, with consistent counters and timings."""
    assert ck.check_status(status(), FRAMES) == []
    assert ck.check_status(status(version=2), FRAMES) == ['layout version 2, expected 3']
    assert ck.check_status(status(frames_mapped=0, frames_in=0), FRAMES) == [
        'no frame mapped yet']
    assert ck.check_status(status(frames_mapped=50), FRAMES)
    assert ck.check_status(status(total_p99_ms=1.0), FRAMES)
    assert ck.check_status(status(awareness_median_ms=math.nan), FRAMES)
    assert ck.check_status(status(uptime_s=0.0), FRAMES)
    assert ck.check_status(status(local_bytes=0), FRAMES)


def test_tf_and_tf_static():
    """world -> body on /tf and body -> sensor on /tf_static, rigid and finite."""
    assert ck.check_tf(tf(transform('map', 'base_link')), FRAMES) == []
    assert ck.check_tf_static(tf(transform('base_link', 'camera_depth_optical_frame',
                                           q=(-0.5, 0.5, -0.5, 0.5))), FRAMES) == []
    assert 'no map -> base_link' in ck.check_tf(tf(transform('odom', 'base_link')), FRAMES)[0]
    assert ck.check_tf(tf(transform('map', 'base_link', q=(0.0, 0.0, 0.0, 0.5))), FRAMES)
    assert ck.check_tf(tf(transform('map', 'base_link', t=(math.nan, 0.0, 0.0))), FRAMES)
    assert ck.check_tf(tf(), FRAMES)


# ---- The bridge's outputs: what markers.py builds must pass ----------------------------------

@pytest.mark.parametrize('layer', CLOUD_LAYERS, ids=lambda layer: layer.name)
def test_the_checker_accepts_what_the_bridge_builds(layer):
    """Each cloud layer through cloud_layer_markers passes check_cube_markers."""
    cloud = esdf_slice() if layer.color_by == 'distance' else occupied_cloud()
    array = read_marker_array(mk.cloud_layer_markers(layer, cloud, defaults()))
    assert ck.check_cube_markers(array, FRAMES) == []


def test_cube_marker_defects_are_reported():
    """No cube list, a DELETE only, colours missing or out of range, zero size."""
    good = read_marker_array(mk.cloud_layer_markers(CLOUD_LAYERS[1], occupied_cloud(),
                                                    defaults()))
    deleted = read_marker_array(mk.cloud_layer_markers(
        CLOUD_LAYERS[1], make_cloud([], XYZ, 12, width=0), defaults()))
    assert ck.check_cube_markers(deleted, FRAMES)
    fewer_colors = copy.deepcopy(good)
    fewer_colors.markers[0].colors = fewer_colors.markers[0].colors[:-1]
    assert ck.check_cube_markers(fewer_colors, FRAMES)
    bright = copy.deepcopy(good)
    bright.markers[0].colors[0].r = 1.5
    assert ck.check_cube_markers(bright, FRAMES) == ['colour channels outside 0..1']
    flat = copy.deepcopy(good)
    flat.markers[0].scale.z = 0.0
    assert ck.check_cube_markers(flat, FRAMES)


def test_the_checker_accepts_the_bridge_status_outputs():
    """The status text marker and String the bridge builds from a Status pass."""
    text = status_text(status())
    array = mk.marker_array(TYPES, mk.text_marker(TYPES, 'base_link', 'status', text, 0.25, 1.5))
    assert ck.check_status_markers(array, FRAMES) == []
    assert ck.check_status_text(SimpleNamespace(data=text), FRAMES) == []
    unknown = status_text(status(version=1))
    assert ck.check_status_text(SimpleNamespace(data=unknown), FRAMES)
    world_text = mk.marker_array(TYPES, mk.text_marker(TYPES, 'map', 'status', text, 0.2, 1.0))
    assert ck.check_status_markers(world_text, FRAMES)
    assert ck.check_status_markers(mk.marker_array(TYPES), FRAMES) == ['no text marker']


# ---- `ros2 topic list` and the verdict -------------------------------------------------------

TOPIC_LIST = """/mlmap/awareness/occupied [sensor_msgs/msg/PointCloud2]
/mlmap/esdf/block [mlmap_msgs/msg/VoxelBlock]
/mlmap/grid [nav_msgs/msg/OccupancyGrid]
/parameter_events [rcl_interfaces/msg/ParameterEvent]
/tf [tf2_msgs/msg/TFMessage]
"""


def test_topic_list_parsing_and_check():
    """Types are compared exactly; missing and mistyped topics are named."""
    topics = ck.parse_topic_list(TOPIC_LIST + '/two [a/msg/A, b/msg/B]\n\n')
    assert topics['/mlmap/esdf/block'] == ['mlmap_msgs/msg/VoxelBlock']
    assert topics['/two'] == ['a/msg/A', 'b/msg/B']
    expected = [e for e in ck.NODE_TOPICS if e.topic in ('/mlmap/grid', '/tf', '/mlmap/status')]
    problems = ck.check_topic_list(topics, expected)
    assert problems == ['/mlmap/status missing from `ros2 topic list`']
    topics['/tf'] = ['tf2_msgs/msg/TFMessage', 'other/msg/T']
    assert 'listed as' in ck.check_topic_list(topics, expected)[1]


def test_verdict():
    """A topic passes once one sample passed; the report names what failed and why."""
    grid_result = ck.TopicResult(ck.NODE_TOPICS[2])  # global map: no rate, stamps checked
    grid_result.record(['every cell unknown'], 100.0, 99.9)
    grid_result.record([], 101.0, 100.9)
    grid_result.record(['every cell unknown'], 102.0, 101.9)
    status_result = ck.TopicResult(ck.NODE_TOPICS[6])
    status_result.record(['no frame mapped yet'])
    silent = ck.TopicResult(ck.NODE_TOPICS[0])
    passed, report = ck.verdict([grid_result, status_result, silent], [])
    assert not passed
    lines = report.splitlines()
    assert lines[0] == ('PASS /mlmap/global_map/occupied [sensor_msgs/msg/PointCloud2] '
                        '(3 samples, 1.0 Hz)')
    assert lines[1].startswith('FAIL /mlmap/status') and 'no frame mapped yet' in lines[1]
    assert lines[2].endswith('(0 samples): no sample received')
    assert lines[-1] == 'FAILED: 1 of 3 topics plausible, ROS graph ok'
    passed, report = ck.verdict([grid_result], ['/tf missing from `ros2 topic list`'])
    assert not passed and 'FAIL ROS graph: /tf missing' in report
    assert ck.verdict([grid_result], [])[0]


def _fed(expectation, rate_hz, count, age_s=0.05, start_s=1000.0):
    """A TopicResult that got count plausible samples at rate_hz, each age_s after its stamp."""
    result = ck.TopicResult(expectation)
    for i in range(count):
        received = start_s + i / rate_hz
        result.record([], received, received - age_s)
    return result


def test_rates_are_checked_against_half_the_nominal_rate():
    """The awareness layer (10 Hz nominal) passes at 6 Hz, fails at 4 Hz or with 2 samples."""
    awareness = ck.NODE_TOPICS[0]
    assert awareness.nominal_hz == 10.0
    assert _fed(awareness, 6.0, 20).timing_problems() == []
    assert _fed(awareness, 6.0, 20).rate_hz() == pytest.approx(6.0)
    slow = _fed(awareness, 4.0, 20).timing_problems()
    assert len(slow) == 1 and 'rate 4.00 Hz, expected >= 5.00 Hz' in slow[0]
    assert 'too few samples' in _fed(awareness, 6.0, 2).timing_problems()[0]
    assert _fed(awareness, 4.0, 20).timing_problems(rate_fraction=0) == []  # disabled
    passed, report = ck.verdict([_fed(awareness, 4.0, 20)], [])
    assert not passed and 'rate 4.00 Hz' in report.splitlines()[0]


def test_freshness_is_the_youngest_samples_age():
    """Stale data, stamps from the future and stampless samples fail; a latched old first
    sample followed by fresh ones passes; tf_static and the overlay text are exempt."""
    local = ck.NODE_TOPICS[1]
    assert _fed(local, 5.0, 10, age_s=0.3).timing_problems() == []
    stale = _fed(local, 5.0, 10, age_s=5.0).timing_problems()
    assert len(stale) == 1 and 'stale: the youngest sample arrived 5.00 s' in stale[0]
    assert 'stale' in _fed(local, 5.0, 10, age_s=-3.0).timing_problems()[0]
    assert _fed(local, 5.0, 10, age_s=5.0).timing_problems(max_age_s=6.0) == []
    latched = ck.TopicResult(ck.NODE_TOPICS[2])
    latched.record([], 50.0, 10.0)  # a map mapped 40 s before the checker started
    latched.record([], 52.0, 51.9)
    assert latched.timing_problems() == []
    stampless = ck.TopicResult(local)
    for i in range(5):
        stampless.record([], 10.0 + i / 5.0, None)
    assert stampless.timing_problems() == ['no sample carries a stamp']
    tf_static = next(e for e in ck.NODE_TOPICS if e.topic == '/tf_static')
    old_static = ck.TopicResult(tf_static)
    old_static.record([], 100.0, 1.0)
    assert old_static.timing_problems() == []
    assert not any(e.fresh for e in ck.BRIDGE_TOPICS if e.topic.endswith(('status', 'text')))


def test_sample_stamps():
    """A header's stamp; the newest of a TFMessage's or MarkerArray's; None when zero."""
    def header(sec, nanosec=0):
        return SimpleNamespace(stamp=SimpleNamespace(sec=sec, nanosec=nanosec))
    assert ck.sample_stamp_s(SimpleNamespace(header=header(3, 500_000_000))) == 3.5
    tf = SimpleNamespace(transforms=[SimpleNamespace(header=header(4)),
                                     SimpleNamespace(header=header(7))])
    assert ck.sample_stamp_s(tf) == 7.0
    assert ck.sample_stamp_s(SimpleNamespace(markers=[SimpleNamespace(header=header(0))])) is None
    assert ck.sample_stamp_s(SimpleNamespace(data='text')) is None


def test_tf_may_come_from_the_robot():
    """/tf and /tf_static are not required to be mlmap_node's (tf_mode none: the robot's)."""
    assert {e.topic for e in ck.NODE_TOPICS if not e.by_node} == {'/tf', '/tf_static'}


def test_the_checker_reads_heavy_layers_best_effort_as_the_bridge_does():
    """BEST_EFFORT exactly on the topics the bridge subscribes to BEST_EFFORT."""
    best_effort = {e.topic for e in ck.NODE_TOPICS if not e.reliable}
    by_topic = {defaults()[f'{layer.name}_topic']: layer for layer in CLOUD_LAYERS}
    assert best_effort == {topic for topic, layer in by_topic.items() if not layer.latched}
    assert all(e.reliable for e in ck.BRIDGE_TOPICS)


# ---- `ros2 node list` and `ros2 topic info -v` --------------------------------------------

NODE_LIST = """/mlmap_bridge
/mlmap_node
/uav1/mlmap_node
"""

TOPIC_INFO = """Type: sensor_msgs/msg/PointCloud2

Publisher count: 1

Node name: mlmap_node
Node namespace: /
Topic type: sensor_msgs/msg/PointCloud2
Topic type hash: RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5
Endpoint type: PUBLISHER
GID: 01.0f.9b.33.10.00.00.00.00.00.00.00.00.00.03.03
QoS profile:
  Reliability: RELIABLE
  History (Depth): UNKNOWN
  Durability: VOLATILE
  Lifespan: Infinite
  Deadline: Infinite
  Liveliness: AUTOMATIC
  Liveliness lease duration: Infinite

Subscription count: 1

Node name: mlmap_bridge
Node namespace: /
Topic type: sensor_msgs/msg/PointCloud2
Topic type hash: RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5
Endpoint type: SUBSCRIPTION
GID: 01.0f.aa.33.10.00.00.00.00.00.00.00.00.00.04.04
QoS profile:
  Reliability: BEST_EFFORT
  History (Depth): UNKNOWN
  Durability: VOLATILE
"""


def test_node_list():
    """mlmap_node once in its namespace; missing or twice is a problem."""
    names = ck.parse_node_list('WARNING: something\n' + NODE_LIST)
    assert names == ['/mlmap_bridge', '/mlmap_node', '/uav1/mlmap_node']
    assert ck.check_node_list(names) == []
    assert ck.check_node_list(names, 'uav1') == []
    assert ck.check_node_list(names, 'uav2')
    assert ck.check_node_list(names + ['/mlmap_node'])


def test_topic_info():
    """The node's publisher with its name, namespace, type, hash and QoS."""
    local = ck.NODE_TOPICS[1]
    count, endpoints = ck.parse_topic_info(TOPIC_INFO)
    assert count == 1 and len(endpoints) == 2
    assert endpoints[0]['Reliability'] == 'RELIABLE'
    assert endpoints[1]['Node name'] == 'mlmap_bridge'
    assert ck.check_topic_info(TOPIC_INFO, local) == []
    assert 'no publisher of node /uav1/mlmap_node' in ck.check_topic_info(TOPIC_INFO, local,
                                                                          'uav1')[0]
    in_uav1 = TOPIC_INFO.replace('Node namespace: /\nTopic', 'Node namespace: /uav1\nTopic', 1)
    assert ck.check_topic_info(in_uav1, local, 'uav1') == []
    assert ck.check_topic_info(in_uav1, local)
    none = TOPIC_INFO.replace('Publisher count: 1', 'Publisher count: 0')
    assert ck.check_topic_info(none, local) == [f'{local.topic}: publisher count 0']
    invalid = TOPIC_INFO.replace('RIHS01_9198', 'INVALID', 1)
    assert 'type hash' in ck.check_topic_info(invalid, local)[0]
    latched = ck.NODE_TOPICS[2]
    assert 'durability VOLATILE, expected TRANSIENT_LOCAL' in ck.check_topic_info(
        TOPIC_INFO, latched)[0]
    best_effort = TOPIC_INFO.replace('RELIABLE', 'BEST_EFFORT', 1)
    assert 'reliability BEST_EFFORT' in ck.check_topic_info(best_effort, local)[0]


def test_every_layer_of_the_node_and_the_bridge_is_expected():
    """The checker waits for all ten node outputs and all bridge outputs, each once."""
    topics = [e.topic for e in ck.EXPECTED_TOPICS]
    assert len(topics) == len(set(topics)) == 10 + len(CLOUD_LAYERS) + 3
    prefix = defaults()['output_prefix']
    for layer in CLOUD_LAYERS:
        e = next(e for e in ck.BRIDGE_TOPICS if e.topic == f'{prefix}/{layer.name}')
        assert e.latched == layer.latched and e.type_name == ck.MARKERS
