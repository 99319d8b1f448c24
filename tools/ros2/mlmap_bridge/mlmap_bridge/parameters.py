"""Every parameter of the bridge node: name, default and description, in one table.

bridge_node.py declares exactly these (with the description as its ParameterDescriptor), and
config/bridge.yaml lists the same defaults for the launch file; test/test_parameters.py checks
that the YAML and this table agree, and the repository's tests check the topic defaults against
mlmap_node's own defaults (config/mlmap_node.yaml).
"""

from dataclasses import dataclass
from typing import Dict, Tuple, Union

Value = Union[str, float, int, bool]


@dataclass(frozen=True)
class Parameter:
    """One ROS parameter of the bridge."""

    name: str
    default: Value
    description: str


@dataclass(frozen=True)
class CloudLayer:
    """A PointCloud2 layer of mlmap_node that the bridge shows as coloured cubes.

    Its parameters are `<name>_topic` and `<name>_max_rate_hz`; its output is
    `<output_prefix>/<name>` and its marker namespace is `name`.
    """

    name: str
    latched: bool          # the node latches it: subscribe RELIABLE + TRANSIENT_LOCAL
    color_by: str          # 'height' (z) or 'distance' (the intensity field, ESDF [m])
    cube_size_parameter: str


CLOUD_LAYERS: Tuple[CloudLayer, ...] = (
    CloudLayer('awareness', False, 'height', 'awareness_cube_size_m'),
    CloudLayer('local_map', False, 'height', 'map_cube_size_m'),
    CloudLayer('global_map', True, 'height', 'map_cube_size_m'),
    CloudLayer('esdf_slice', False, 'distance', 'map_cube_size_m'),
)

PARAMETERS = (
    # Inputs: mlmap_node's topics (its defaults, without a namespace).
    Parameter('awareness_topic', '/mlmap/awareness/occupied',
              'mlmap awareness layer in (sensor_msgs/PointCloud2, BEST_EFFORT); "" disables it'),
    Parameter('local_map_topic', '/mlmap/local_map/occupied',
              'mlmap local map in (sensor_msgs/PointCloud2, BEST_EFFORT); "" disables it'),
    Parameter('global_map_topic', '/mlmap/global_map/occupied',
              'mlmap global map in (sensor_msgs/PointCloud2, RELIABLE + TRANSIENT_LOCAL, as '
              'the node latches it); "" disables it'),
    Parameter('esdf_slice_topic', '/mlmap/esdf/slice',
              'mlmap ESDF slice in (sensor_msgs/PointCloud2 with intensity = distance [m], '
              'BEST_EFFORT); "" disables it'),
    Parameter('grid_topic', '/mlmap/grid',
              'mlmap 2D grid in (nav_msgs/OccupancyGrid, RELIABLE + TRANSIENT_LOCAL); '
              '"" disables it'),
    Parameter('status_topic', '/mlmap/status',
              'mlmap status in (mlmap_msgs/Status); "" disables it'),
    Parameter('fleet_map_topic', '',
              "mlmap_fleet's merged map in (sensor_msgs/PointCloud2 with rgb per vehicle, "
              'RELIABLE + TRANSIENT_LOCAL), absolute: not under `namespace`; its default is '
              '/mlmap/fleet/occupied; "" (default) disables it and the paths'),
    Parameter('fleet_status_topic', '/mlmap/fleet/status',
              "mlmap_fleet's status in (mlmap_msgs/FleetStatus), absolute: its vehicle order "
              'gives each path the colour the merged map gives the vehicle; "": order seen'),
    # Outputs.
    Parameter('output_prefix', '/mlmap/viz',
              'RViz topics out: <prefix>/awareness, /local_map, /global_map, /esdf_slice '
              '(visualization_msgs/MarkerArray), /grid (nav_msgs/OccupancyGrid), /status '
              '(MarkerArray with a text), /status_text (std_msgs/String) and, with '
              'fleet_map_topic, /fleet_map (MarkerArray coloured by vehicle, latched) and '
              '/fleet_paths (a line strip per vehicle from /tf, <vehicle>/<body_frame>)'),
    Parameter('body_frame', 'base_link',
              'frame the status text floats above (mlmap_node dds.body_frame)'),
    Parameter('namespace', '',
              "mlmap_node's dds.ns: the *_topic parameters and output_prefix (written as "
              'without a namespace) are taken under /<namespace>; "" for none'),
    Parameter('frame_prefix', '',
              "mlmap_node's dds.frame_prefix: body_frame becomes <frame_prefix>/<body_frame>; "
              '"" for none'),
    # Rates: the bridge converts a layer at most this often [Hz]; 0: every message.
    Parameter('awareness_max_rate_hz', 5.0, 'most awareness conversions per second; 0: all'),
    Parameter('local_map_max_rate_hz', 2.0, 'most local-map conversions per second; 0: all'),
    Parameter('global_map_max_rate_hz', 0.5, 'most global-map conversions per second; 0: all'),
    Parameter('esdf_slice_max_rate_hz', 2.0, 'most ESDF-slice conversions per second; 0: all'),
    Parameter('grid_max_rate_hz', 2.0, 'most grid messages passed on per second; 0: all'),
    Parameter('fleet_map_max_rate_hz', 0.5, 'most fleet-map conversions per second; 0: all'),
    # Looks.
    Parameter('max_cubes', 100000,
              'most cubes in one layer marker; larger clouds are thinned evenly (RViz and '
              'the Python conversion slow down with millions of cubes)'),
    Parameter('awareness_cube_size_m', 0.1,
              'edge of the awareness cubes [m] (its cells are cylindrical: about '
              'awareness.rho_resolution_m)'),
    Parameter('map_cube_size_m', 0.0,
              'edge of the local, global and ESDF cubes [m]; 0: the voxel edge found in '
              'each cloud (local_map.resolution_m of the node)'),
    Parameter('height_min_m', 0.0, 'height that gets the low end of the colour scale [m]'),
    Parameter('height_max_m', 4.0,
              'height that gets the high end of the colour scale [m]; <= height_min_m: the '
              'range of each cloud'),
    Parameter('esdf_max_distance_m', 2.0,
              'distance that gets the far (green) end of the ESDF colour scale [m] '
              '(esdf.max_distance_m of the node)'),
    Parameter('text_height_m', 0.25, 'height of the status text letters [m]'),
    Parameter('text_offset_z_m', 1.5, 'how far above the body frame the status text floats [m]'),
)


def defaults() -> Dict[str, Value]:
    """Map every parameter name to its default."""
    return {p.name: p.default for p in PARAMETERS}


def in_namespace(namespace: str, topic: str) -> str:
    """Return `topic` (a name of mlmap_node's without its namespace) under /<namespace>.

    As mlmap_node names its topics rt/<ns>/<name>: ('uav1', '/mlmap/grid') -> '/uav1/mlmap/grid';
    an empty namespace leaves the topic as it is, and an empty topic (disabled) stays empty.
    """
    if not topic or not namespace.strip('/'):
        return topic
    return '/' + namespace.strip('/') + '/' + topic.lstrip('/')


def prefixed_frame(prefix: str, frame: str) -> str:
    """Return `frame` with mlmap_node's dds.frame_prefix ('uav1', 'base_link': uav1/base_link)."""
    return f'{prefix.strip("/")}/{frame}' if prefix.strip('/') else frame
