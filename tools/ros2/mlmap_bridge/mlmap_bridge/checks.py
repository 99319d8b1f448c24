"""What counts as "this layer reached ROS 2 intact": the integration checker's judgement.

checker_node.py (rclpy) subscribes to every topic below in the ground-station container and
feeds each sample to its check; this module holds the checks, without importing rclpy, so the
unit tests run them on hand-built messages (test/test_checks.py). A check returns the list of
problems it found; an empty list means the sample is plausible.

Plausible means what a correct mlmap_node and bridge produce in any world: the right frame,
fields and sizes; finite values in their documented ranges; voxel centres on the voxel grid;
a mapping node that has mapped frames. Nothing here depends on the simulated room.
"""

from dataclasses import dataclass
import math
from typing import Callable, Dict, Iterable, List, Optional, Tuple

import numpy as np

from .conversions import CloudLayoutError, grid_spacing, read_cloud_fields
from .marker_cdr import CUBE_LIST, TEXT_VIEW_FACING
from .parameters import in_namespace

FLOAT32 = 7
SUPPORTED_VERSION = 1         # mlmap_msgs/VoxelBlock
SUPPORTED_STATUS_VERSION = 3  # mlmap_msgs/Status (frame checks since 2, window hits since 3)
MAX_COORDINATE_M = 1.0e5   # a map coordinate beyond this is garbage, not a place
GRID_TOLERANCE = 0.01      # voxels: how far from (i + 0.5) * edge a centre may sit
RATE_FRACTION = 0.5        # a topic keeps its rate at half its nominal rate or more
MAX_AGE_S = 2.0            # fresh: the youngest sample's stamp at most this old on arrival
NODE_NAME = 'mlmap_node'

Check = Callable[[object, 'Frames'], List[str]]


@dataclass(frozen=True)
class Frames:
    """The frames mlmap_node was configured with (dds.world_frame, body_frame, sensor_frame).

    The body and sensor frames carry dds.frame_prefix when the node has one.
    """

    world: str = 'map'
    body: str = 'base_link'
    sensor: str = 'camera_depth_optical_frame'


def _frame(header, expected: str) -> List[str]:
    """Check a header's frame_id."""
    if header.frame_id != expected:
        return [f'frame_id {header.frame_id!r}, expected {expected!r}']
    return []


def _cloud_fields(msg, names: Tuple[str, ...]) -> Tuple[Optional[np.ndarray], List[str]]:
    """Decode the named fields of a cloud, or return the reason it cannot be decoded."""
    try:
        values = read_cloud_fields(msg, names)
    except CloudLayoutError as error:
        return None, [f'undecodable cloud: {error}']
    problems = []
    total = int(msg.width) * int(msg.height)
    if len(values) != total:
        problems.append(f'{total - len(values)} of {total} points are not finite')
    return values, problems


def _float32_xyz(msg) -> List[str]:
    """Check x, y, z are float32 at offsets 0, 4, 8, as mlmap_node writes them."""
    layout = {f.name: (int(f.offset), int(f.datatype)) for f in msg.fields}
    expected = {'x': (0, FLOAT32), 'y': (4, FLOAT32), 'z': (8, FLOAT32)}
    wrong = [n for n, v in expected.items() if layout.get(n) != v]
    return [f'fields {wrong} not float32 at 0/4/8: {layout}'] if wrong else []


def voxel_edge(xyz: np.ndarray) -> Optional[float]:
    """Estimate the voxel edge of a cloud of voxel centres to float32 precision, or None.

    grid_spacing gives it to about 1e-5 m. Dividing the widest extent by the number of voxels
    it spans refines that enough to number every centre, (i + 0.5) * edge; a least-squares fit
    of the edge to those numbers then makes it as exact as the float32 centres allow, so the
    grid test below holds hundreds of metres from the origin.
    """
    edge = grid_spacing(xyz)
    if edge is None:
        return None
    span = float((xyz.max(axis=0) - xyz.min(axis=0)).max())
    edge = span / max(1, round(span / edge))
    cells = np.round(xyz / edge - 0.5) + 0.5
    return float(np.sum(xyz * cells) / np.sum(cells * cells))


def _on_voxel_grid(xyz: np.ndarray) -> List[str]:
    """Check that points are voxel centres (i + 0.5) * edge of the world-aligned grid."""
    edge = voxel_edge(xyz)
    if edge is None:
        return []  # fewer than two distinct coordinates on every axis: nothing to compare
    cells = xyz / edge - 0.5
    off = float(np.abs(cells - np.round(cells)).max())
    # float32 centres: about 1e-7 of the coordinate; anything near 0.5 voxel is off the grid.
    if off > GRID_TOLERANCE + 1e-6 * float(np.abs(cells).max()):
        return [f'points are not voxel centres of a {edge:.4f} m grid (off by {off:.3g} voxel)']
    return []


def check_occupied_cloud(msg, frames: Frames, on_grid: bool = True) -> List[str]:
    """Check an occupied-voxel layer: world frame, finite points, on the voxel grid."""
    problems = _frame(msg.header, frames.world) + _float32_xyz(msg)
    xyz, decode_problems = _cloud_fields(msg, ('x', 'y', 'z'))
    problems += decode_problems
    if xyz is None:
        return problems
    if len(xyz) == 0:
        return problems + ['no points']
    if np.abs(xyz).max() > MAX_COORDINATE_M:
        problems.append(f'coordinates up to {np.abs(xyz).max():.3g} m')
    if on_grid:
        problems += _on_voxel_grid(xyz)
    return problems


def check_awareness_cloud(msg, frames: Frames) -> List[str]:
    """Check the awareness layer: cylindrical cell centres, so not on a Cartesian grid."""
    return check_occupied_cloud(msg, frames, on_grid=False)


def check_esdf_slice(msg, frames: Frames) -> List[str]:
    """Check the ESDF slice: one voxel layer (one z) of centres with finite distances."""
    problems = _frame(msg.header, frames.world) + _float32_xyz(msg)
    values, decode_problems = _cloud_fields(msg, ('x', 'y', 'z', 'intensity'))
    problems += decode_problems
    if values is None:
        return problems
    if len(values) == 0:
        return problems + ['no points']
    z = values[:, 2]
    if np.ptp(z) > 1e-4:
        problems.append(f'z spans {z.min():.3f}..{z.max():.3f} m; a slice has one layer')
    problems += _on_voxel_grid(values[:, :3])
    if not (values[:, 3] > 0).any():
        problems.append('no positive distance: no free space in the slice')
    return problems


def check_grid(msg, frames: Frames) -> List[str]:
    """Check a nav_msgs/OccupancyGrid: sizes agree, cells in {-1, 0..100}, some cells observed."""
    problems = _frame(msg.header, frames.world)
    info = msg.info
    cells = np.asarray(msg.data, dtype=np.int64)
    if not info.resolution > 0:
        problems.append(f'resolution {info.resolution}')
    if int(info.width) * int(info.height) != cells.size or cells.size == 0:
        problems.append(f'{cells.size} cells for {info.width} x {info.height}')
    bad = cells[(cells != -1) & ((cells < 0) | (cells > 100))]
    if bad.size:
        problems.append(f'{bad.size} cells outside -1 and 0..100, e.g. {int(bad[0])}')
    if cells.size and not (cells >= 0).any():
        problems.append('every cell unknown')
    q = info.origin.orientation
    if abs(math.sqrt(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2) - 1.0) > 1e-3:
        problems.append('origin orientation is not a unit quaternion')
    return problems


def check_voxel_block(msg, frames: Frames) -> List[str]:
    """Check a mlmap_msgs/VoxelBlock (ESDF): version, sizes, values within +-max_value or NaN."""
    if int(msg.version) != SUPPORTED_VERSION:
        return [f'layout version {msg.version}, expected {SUPPORTED_VERSION}']
    problems = _frame(msg.header, frames.world)
    if msg.layer != 'esdf':
        problems.append(f'layer {msg.layer!r}, expected "esdf"')
    if not msg.resolution > 0 or not msg.max_value > 0:
        problems.append(f'resolution {msg.resolution}, max_value {msg.max_value}')
    values = np.asarray(msg.values, dtype=np.float64)
    size = int(msg.size_x) * int(msg.size_y) * int(msg.size_z)
    if size != values.size or size == 0:
        problems.append(f'{values.size} values for {msg.size_x} x {msg.size_y} x {msg.size_z}')
    known = values[~np.isnan(values)]
    if known.size == 0:
        return problems + ['every voxel unknown (NaN)']
    limit = float(msg.max_value) * (1 + 1e-6)
    if not np.isfinite(known).all() or np.abs(known).max() > limit:
        problems.append(f'values beyond +-{msg.max_value}: {known.min():.3g}..{known.max():.3g}')
    if not (known > 0).any():
        problems.append('no positive distance: no free space')
    return problems


def check_status(msg, frames: Frames) -> List[str]:
    """Check a mlmap_msgs/Status: version, frames mapped, consistent counters and timings."""
    if int(msg.version) != SUPPORTED_STATUS_VERSION:
        return [f'layout version {msg.version}, expected {SUPPORTED_STATUS_VERSION}']
    problems = _frame(msg.header, frames.world)
    if not msg.uptime_s > 0:
        problems.append(f'uptime {msg.uptime_s}')
    if int(msg.frames_mapped) < 1:
        problems.append('no frame mapped yet')
    if int(msg.frames_mapped) > int(msg.frames_in):
        problems.append(f'{msg.frames_mapped} frames mapped of {msg.frames_in} received')
    for stage in ('awareness', 'local_global', 'total'):
        median = getattr(msg, f'{stage}_median_ms')
        p99 = getattr(msg, f'{stage}_p99_ms')
        if not (math.isfinite(median) and math.isfinite(p99) and 0 <= median <= p99):
            problems.append(f'{stage} median {median} ms, p99 {p99} ms')
    if int(msg.local_bytes) <= 0:
        problems.append('local map memory 0')
    return problems


def _transform_problems(transforms: Iterable, parent: str, child: str) -> List[str]:
    """Find parent -> child among the transforms and check it is a proper rigid transform."""
    found = [t for t in transforms if t.header.frame_id == parent and t.child_frame_id == child]
    if not found:
        pairs = [(t.header.frame_id, t.child_frame_id) for t in transforms]
        return [f'no {parent} -> {child} transform among {pairs}']
    t = found[-1].transform
    values = [t.translation.x, t.translation.y, t.translation.z]
    q = t.rotation
    if not all(math.isfinite(v) for v in values):
        return [f'{parent} -> {child}: translation {values}']
    if abs(math.sqrt(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2) - 1.0) > 1e-3:
        return [f'{parent} -> {child}: rotation is not a unit quaternion']
    return []


def check_tf(msg, frames: Frames) -> List[str]:
    """Check rt/tf: the vehicle's pose, world -> body."""
    return _transform_problems(msg.transforms, frames.world, frames.body)


def check_tf_static(msg, frames: Frames) -> List[str]:
    """Check rt/tf_static: the sensor mounting, body -> sensor."""
    return _transform_problems(msg.transforms, frames.body, frames.sensor)


def check_cube_markers(msg, frames: Frames) -> List[str]:
    """Check a bridge layer: a CUBE_LIST in the world frame with one colour per cube."""
    cubes = [m for m in msg.markers if m.type == CUBE_LIST]
    if not cubes:
        return [f'no CUBE_LIST marker among {len(msg.markers)} markers']
    problems = []
    for m in cubes:
        problems += _frame(m.header, frames.world)
        if not m.points or len(m.points) != len(m.colors):
            problems.append(f'{len(m.points)} cubes, {len(m.colors)} colours')
        if not min(m.scale.x, m.scale.y, m.scale.z) > 0:
            problems.append(f'cube size {m.scale.x} x {m.scale.y} x {m.scale.z}')
        channels = [v for c in m.colors for v in (c.r, c.g, c.b, c.a)]
        if channels and not (0.0 <= min(channels) and max(channels) <= 1.0):
            problems.append('colour channels outside 0..1')
    return problems


def check_status_markers(msg, frames: Frames) -> List[str]:
    """Check the bridge's status overlay: a text at the body frame that reports mapping."""
    texts = [m for m in msg.markers if m.type == TEXT_VIEW_FACING]
    if not texts:
        return ['no text marker']
    problems = _frame(texts[0].header, frames.body)
    if 'frames mapped' not in texts[0].text:
        problems.append(f'text does not report mapping: {texts[0].text!r}')
    return problems


def check_status_text(msg, frames: Frames) -> List[str]:
    """Check the bridge's status as std_msgs/String."""
    return [] if 'frames mapped' in msg.data else [f'text: {msg.data!r}']


@dataclass(frozen=True)
class Expectation:
    """A topic that must reach ROS 2: its type, QoS, rate, freshness and its check."""

    topic: str
    type_name: str      # as `ros2 topic list -t` prints it
    latched: bool       # published TRANSIENT_LOCAL: subscribe so, to get the latched sample
    check: Check
    reliable: bool = True   # False: subscribed BEST_EFFORT, as the bridge reads it
    nominal_hz: float = 0.0  # mlmap_node's default rate (rates.*); 0: the rate is not checked
    fresh: bool = True      # the samples carry the stamp of recent data (checked on arrival)
    # mlmap_node itself publishes it (False: the node or the robot, by dds.tf_mode and
    # dds.publish_sensor_tf)
    by_node: bool = True


CLOUD = 'sensor_msgs/msg/PointCloud2'
MARKERS = 'visualization_msgs/msg/MarkerArray'


def node_topics(namespace: str = '') -> Tuple[Expectation, ...]:
    """Return mlmap_node's outputs (idl/README.md, default names) under its dds.ns `namespace`.

    tf and tf_static stay absolute, as tf2 listens to them.
    """

    def ns(topic: str) -> str:
        return in_namespace(namespace, topic)
    return (
        Expectation(ns('/mlmap/awareness/occupied'), CLOUD, False, check_awareness_cloud,
                    reliable=False, nominal_hz=10.0),
        Expectation(ns('/mlmap/local_map/occupied'), CLOUD, False, check_occupied_cloud,
                    reliable=False, nominal_hz=5.0),
        # Sent only when it changed: no rate of its own.
        Expectation(ns('/mlmap/global_map/occupied'), CLOUD, True, check_occupied_cloud),
        Expectation(ns('/mlmap/grid'), 'nav_msgs/msg/OccupancyGrid', True, check_grid,
                    nominal_hz=2.0),
        Expectation(ns('/mlmap/esdf/slice'), CLOUD, False, check_esdf_slice,
                    reliable=False, nominal_hz=2.0),
        Expectation(ns('/mlmap/esdf/block'), 'mlmap_msgs/msg/VoxelBlock', False,
                    check_voxel_block, nominal_hz=2.0),
        Expectation(ns('/mlmap/status'), 'mlmap_msgs/msg/Status', False, check_status,
                    nominal_hz=1.0),
        Expectation('/tf', 'tf2_msgs/msg/TFMessage', False, check_tf, by_node=False),
        # The mounting: static, its stamp may be old or zero.
        Expectation('/tf_static', 'tf2_msgs/msg/TFMessage', True, check_tf_static, fresh=False,
                    by_node=False),
        Expectation(ns('/mlmap/map'), 'nav_msgs/msg/OccupancyGrid', True, check_grid),
    )


def bridge_topics(namespace: str = '',
                  output_prefix: str = '/mlmap/viz') -> Tuple[Expectation, ...]:
    """Return the bridge's outputs with its parameters `namespace` and `output_prefix`."""
    prefix = in_namespace(namespace, output_prefix).rstrip('/')
    # The overlay text has a zero stamp (RViz places it with the latest TF); a String has none.
    return (
        Expectation(f'{prefix}/awareness', MARKERS, False, check_cube_markers),
        Expectation(f'{prefix}/local_map', MARKERS, False, check_cube_markers),
        Expectation(f'{prefix}/global_map', MARKERS, True, check_cube_markers),
        Expectation(f'{prefix}/esdf_slice', MARKERS, False, check_cube_markers),
        Expectation(f'{prefix}/grid', 'nav_msgs/msg/OccupancyGrid', True, check_grid),
        Expectation(f'{prefix}/status', MARKERS, False, check_status_markers, fresh=False),
        Expectation(f'{prefix}/status_text', 'std_msgs/msg/String', False, check_status_text,
                    fresh=False),
    )


# The defaults: mlmap_node's outputs without a namespace and the bridge's default parameters.
NODE_TOPICS = node_topics()
BRIDGE_TOPICS = bridge_topics()
EXPECTED_TOPICS = NODE_TOPICS + BRIDGE_TOPICS


def parse_topic_list(output: str) -> Dict[str, List[str]]:
    """Parse `ros2 topic list -t` output ("/topic [pkg/msg/Type]" a line) into topic -> types."""
    topics: Dict[str, List[str]] = {}
    for line in output.splitlines():
        line = line.strip()
        if not line:
            continue
        name, _, rest = line.partition(' ')
        types = rest.strip().strip('[]')
        topics[name] = [t.strip() for t in types.split(',') if t.strip()]
    return topics


def check_topic_list(topics: Dict[str, List[str]],
                     expected: Iterable[Expectation] = EXPECTED_TOPICS) -> List[str]:
    """Every expected topic is listed, with its type and no other."""
    problems = []
    for e in expected:
        if e.topic not in topics:
            problems.append(f'{e.topic} missing from `ros2 topic list`')
        elif topics[e.topic] != [e.type_name]:
            problems.append(f'{e.topic} listed as {topics[e.topic]}, expected {e.type_name}')
    return problems


def sample_stamp_s(msg) -> Optional[float]:
    """Return the newest header stamp of a sample [s], or None when it carries none (or zero).

    A message with a header gives its stamp; a TFMessage or MarkerArray the newest of its
    transforms' or markers' stamps.
    """
    headers = []
    if hasattr(msg, 'header'):
        headers = [msg.header]
    elif hasattr(msg, 'transforms'):
        headers = [t.header for t in msg.transforms]
    elif hasattr(msg, 'markers'):
        headers = [m.header for m in msg.markers]
    stamps = [h.stamp.sec + h.stamp.nanosec * 1e-9 for h in headers]
    stamps = [t for t in stamps if t > 0]
    return max(stamps) if stamps else None


@dataclass
class TopicResult:
    """What the checker saw on one topic: plausibility, arrival times and ages."""

    expectation: Expectation
    samples: int = 0
    passed: bool = False
    last_problems: Tuple[str, ...] = ('no sample received',)
    first_arrival_s: Optional[float] = None
    last_arrival_s: Optional[float] = None
    youngest_age_s: Optional[float] = None

    def record(self, problems: List[str], received_s: Optional[float] = None,
               stamp_s: Optional[float] = None) -> None:
        """Count a sample received at received_s (wall clock [s]) with stamp_s (or None).

        One plausible sample passes the topic for good: early samples may fairly fail (a
        status before the first frame is mapped, a grid still all unknown), so a failure
        after a pass changes nothing.
        """
        self.samples += 1
        if not problems:
            self.passed = True
        elif not self.passed:
            self.last_problems = tuple(problems)
        if received_s is not None:
            if self.first_arrival_s is None:
                self.first_arrival_s = received_s
            self.last_arrival_s = received_s
            if stamp_s is not None:
                age = received_s - stamp_s
                if self.youngest_age_s is None or age < self.youngest_age_s:
                    self.youngest_age_s = age

    def rate_hz(self) -> Optional[float]:
        """Return the samples per second between the first and last arrival (None below 3)."""
        if self.samples < 3 or self.last_arrival_s <= self.first_arrival_s:
            return None
        return (self.samples - 1) / (self.last_arrival_s - self.first_arrival_s)

    def timing_problems(self, rate_fraction: float = RATE_FRACTION,
                        max_age_s: float = MAX_AGE_S) -> List[str]:
        """Check the rate (at least rate_fraction of nominal) and freshness of the samples.

        A latched first sample may be old, so freshness looks at the youngest sample: the
        topic is fresh when some sample arrived at most max_age_s after its stamp (a stamp
        ahead of the receiver's clock by more than max_age_s is a clock problem, reported too).
        """
        e, problems = self.expectation, []
        if e.nominal_hz > 0 and rate_fraction > 0 and self.samples:
            rate = self.rate_hz()
            wanted = rate_fraction * e.nominal_hz
            if rate is None or rate < wanted:
                got = 'too few samples' if rate is None else f'{rate:.2f} Hz'
                problems.append(f'rate {got}, expected >= {wanted:.2f} Hz '
                                f'({rate_fraction:g} of {e.nominal_hz:g} Hz)')
        if e.fresh and self.samples:
            age = self.youngest_age_s
            if age is None:
                problems.append('no sample carries a stamp')
            elif not -max_age_s <= age <= max_age_s:
                problems.append(f'stale: the youngest sample arrived {age:.2f} s after its '
                                f'stamp (at most {max_age_s:g} s)')
        return problems


def parse_node_list(output: str) -> List[str]:
    """Parse `ros2 node list` output (one fully qualified node name a line)."""
    return [line.strip() for line in output.splitlines() if line.strip().startswith('/')]


def node_fqn(namespace: str = '') -> str:
    """Return the fully qualified name of mlmap_node in its dds.ns namespace."""
    return in_namespace(namespace, f'/{NODE_NAME}')


def check_node_list(names: List[str], namespace: str = '') -> List[str]:
    """mlmap_node is in the graph, exactly once."""
    count = names.count(node_fqn(namespace))
    if count != 1:
        return [f'{node_fqn(namespace)} listed {count} times among {names}']
    return []


def parse_topic_info(output: str) -> Tuple[Optional[int], List[Dict[str, str]]]:
    """Parse `ros2 topic info -v`: the publisher count and each endpoint's "Key: value" lines.

    Endpoints are the blocks that start with "Node name:"; nested QoS lines (indented) are kept
    under their own keys ("Reliability", "Durability", ...).
    """
    count, endpoints = None, []
    for line in output.splitlines():
        key, sep, value = line.strip().partition(':')
        if not sep:
            continue
        value = value.strip()
        if key == 'Publisher count':
            count = int(value)
        elif key == 'Node name':
            endpoints.append({key: value})
        elif endpoints:
            endpoints[-1].setdefault(key, value)
    return count, endpoints


def check_topic_info(output: str, e: Expectation, namespace: str = '') -> List[str]:
    """mlmap_node's publisher of e is in `ros2 topic info -v`: its node, type, hash and QoS."""
    count, endpoints = parse_topic_info(output)
    if not count:
        return [f'{e.topic}: publisher count {count}']
    node_ns = '/' + namespace.strip('/')
    ours = [p for p in endpoints if p.get('Endpoint type') == 'PUBLISHER'
            and p.get('Node name') == NODE_NAME and p.get('Node namespace') == node_ns]
    if not ours:
        return [f'{e.topic}: no publisher of node {node_fqn(namespace)} among {count}']
    p, problems = ours[0], []
    if p.get('Topic type') != e.type_name:
        problems.append(f'{e.topic}: type {p.get("Topic type")}, expected {e.type_name}')
    if not p.get('Topic type hash', '').startswith('RIHS01_'):
        problems.append(f'{e.topic}: type hash {p.get("Topic type hash")!r}')
    if p.get('Reliability') != 'RELIABLE':
        problems.append(f'{e.topic}: reliability {p.get("Reliability")}, expected RELIABLE')
    durability = 'TRANSIENT_LOCAL' if e.latched else 'VOLATILE'
    if p.get('Durability') != durability:
        problems.append(f'{e.topic}: durability {p.get("Durability")}, expected {durability}')
    return problems


def verdict(results: Iterable[TopicResult], graph_problems: List[str],
            rate_fraction: float = RATE_FRACTION,
            max_age_s: float = MAX_AGE_S) -> Tuple[bool, str]:
    """Return (passed, report): one line per topic, then the ROS graph's findings.

    A topic passes when one sample was plausible and its rate and freshness hold;
    graph_problems are what `ros2 topic list`, `ros2 node list` and `ros2 topic info` found.
    """
    lines, failed, count = [], 0, 0
    for r in results:
        count += 1
        e = r.expectation
        problems = ([] if r.passed else list(r.last_problems)) + r.timing_problems(
            rate_fraction, max_age_s)
        rate = r.rate_hz()
        seen = f'{r.samples} samples' + (f', {rate:.1f} Hz' if rate is not None else '')
        if not problems:
            lines.append(f'PASS {e.topic} [{e.type_name}] ({seen})')
        else:
            failed += 1
            lines.append(f'FAIL {e.topic} [{e.type_name}] ({seen}): ' + '; '.join(problems))
    for problem in graph_problems:
        lines.append(f'FAIL ROS graph: {problem}')
    if not graph_problems:
        lines.append('PASS ROS graph: topics with their types, the node, its publishers')
    passed = failed == 0 and not graph_problems
    lines.append(f'{"PASSED" if passed else "FAILED"}: {count - failed} of {count} topics '
                 f'plausible, ROS graph {"ok" if not graph_problems else "wrong"}')
    return passed, '\n'.join(lines)
