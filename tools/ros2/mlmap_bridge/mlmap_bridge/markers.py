"""Builds the RViz2 messages of the bridge from numpy arrays, without importing rclpy.

The message classes come in as arguments (`MessageTypes`): the node passes the real ones
(visualization_msgs/Marker, geometry_msgs/Point, ...), the tests pass strict stand-ins that
check field names and Python types as rclpy's generated classes do. So the code that fills
markers runs in the unit tests, and only the topic wiring is left to bridge_node.py.
"""

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from .conversions import cloud_xyz, distance_colors, grid_spacing, height_colors
from .conversions import read_cloud_fields, thin_evenly
from .parameters import CloudLayer

# visualization_msgs/Marker constants.
CUBE_LIST = 6
TEXT_VIEW_FACING = 9
ADD = 0
DELETE = 2

# mlmap's default local_map.resolution_m: the cube edge when a cloud does not show its own.
DEFAULT_VOXEL_EDGE_M = 0.2


@dataclass(frozen=True)
class MessageTypes:
    """The message classes the builders instantiate."""

    Marker: Any
    MarkerArray: Any
    Point: Any
    ColorRGBA: Any
    Header: Any


def cube_list(types: MessageTypes, header, ns: str, xyz: np.ndarray, rgba: np.ndarray,
              size_m: float):
    """Make a CUBE_LIST marker with one cube of edge size_m per point, each its own colour.

    An empty cloud gives a DELETE of the same marker, so RViz drops what it showed before.
    """
    if len(xyz) != len(rgba):
        raise ValueError(f'{len(xyz)} points but {len(rgba)} colours')
    marker = types.Marker()
    marker.header = header
    marker.ns = ns
    marker.id = 0
    if len(xyz) == 0:
        marker.action = DELETE
        return marker
    if not size_m > 0:
        raise ValueError(f'cube size must be positive, got {size_m}')
    marker.type = CUBE_LIST
    marker.action = ADD
    marker.pose.orientation.w = 1.0
    marker.scale.x = marker.scale.y = marker.scale.z = float(size_m)
    marker.color.r = marker.color.g = marker.color.b = marker.color.a = 1.0
    marker.points = [types.Point(x=x, y=y, z=z) for x, y, z in np.asarray(xyz, float).tolist()]
    marker.colors = [types.ColorRGBA(r=r, g=g, b=b, a=a)
                     for r, g, b, a in np.asarray(rgba, float).tolist()]
    return marker


def text_marker(types: MessageTypes, frame_id: str, ns: str, text: str, height_m: float,
                offset_z_m: float):
    """Make a TEXT_VIEW_FACING marker offset_z_m above the origin of frame_id (always readable).

    The stamp stays zero, so RViz places it with the latest transform of that frame.
    """
    header = types.Header()
    header.frame_id = frame_id
    marker = types.Marker()
    marker.header = header
    marker.ns = ns
    marker.id = 0
    marker.type = TEXT_VIEW_FACING
    marker.action = ADD
    marker.pose.position.z = float(offset_z_m)
    marker.pose.orientation.w = 1.0
    marker.scale.z = float(height_m)
    marker.color.r = marker.color.g = marker.color.b = marker.color.a = 1.0
    marker.text = text
    return marker


def marker_array(types: MessageTypes, *markers):
    """Wrap markers into a MarkerArray."""
    array = types.MarkerArray()
    array.markers = list(markers)
    return array


def cloud_layer_markers(types: MessageTypes, layer: CloudLayer, cloud,
                        settings: Mapping[str, Any]):
    """Turn one PointCloud2 of a mlmap layer into the MarkerArray RViz shows.

    settings holds the bridge's parameters by name (max_cubes, the layer's cube size,
    height_min_m / height_max_m, esdf_max_distance_m). Cubes are coloured by height, or by
    the `intensity` field (the ESDF distance) for a layer coloured by distance. The cube edge
    is the layer's parameter or, when that is 0, the voxel edge found in the whole cloud
    (mlmap's default 0.2 m when no axis has two distinct coordinates). Clouds larger than
    max_cubes are thinned evenly after that.
    """
    if layer.color_by == 'distance':
        fields = read_cloud_fields(cloud, ('x', 'y', 'z', 'intensity'))
        xyz, distance = fields[:, :3], fields[:, 3]
    elif layer.color_by == 'height':
        xyz, distance = cloud_xyz(cloud), None
    else:
        raise ValueError(f'layer {layer.name}: unknown colouring {layer.color_by!r}')
    size_m = float(settings[layer.cube_size_parameter])
    if size_m <= 0:
        size_m = grid_spacing(xyz) or DEFAULT_VOXEL_EDGE_M
    keep = thin_evenly(len(xyz), int(settings['max_cubes']))
    xyz = xyz[keep]
    if distance is not None:
        rgba = distance_colors(distance[keep], float(settings['esdf_max_distance_m']))
    else:
        rgba = height_colors(xyz[:, 2], float(settings['height_min_m']),
                             float(settings['height_max_m']))
    return marker_array(types, cube_list(types, cloud.header, layer.name, xyz, rgba, size_m))
