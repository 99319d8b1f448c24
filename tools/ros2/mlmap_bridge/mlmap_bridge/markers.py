"""Builds the RViz2 messages of the bridge from numpy arrays, without importing rclpy.

The cube lists of the map layers are serialised straight from numpy arrays (marker_cdr.py):
no Python object per voxel. The small text marker is filled into message classes that come in
as arguments (`MessageTypes`): the node passes the real ones, the tests strict stand-ins that
check field names and Python types as rclpy's generated classes do. So the code that fills
markers runs in the unit tests, and only the topic wiring is left to bridge_node.py.
"""

from dataclasses import dataclass
from typing import Any, Mapping

from .conversions import cloud_xyz, distance_colors, grid_spacing, height_colors
from .conversions import packed_rgb_colors
from .conversions import read_cloud_fields, thin_evenly
from .marker_cdr import ADD, cube_list_array, TEXT_VIEW_FACING
from .parameters import CloudLayer

# mlmap's default local_map.resolution_m: the cube edge when a cloud does not show its own.
DEFAULT_VOXEL_EDGE_M = 0.2


@dataclass(frozen=True)
class MessageTypes:
    """The message classes the builders instantiate."""

    Marker: Any
    MarkerArray: Any
    Header: Any
    Point: Any = None  # geometry_msgs/Point, for the vehicles' paths (fleet_paths.py)


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


def cloud_layer_markers(layer: CloudLayer, cloud, settings: Mapping[str, Any]) -> bytes:
    """Turn one PointCloud2 of a mlmap layer into the MarkerArray RViz shows, serialised.

    The result is a CDR MarkerArray with one cube list (marker_cdr.cube_list_array), which
    rclpy's Publisher.publish() takes as is.
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
    stamp = cloud.header.stamp
    return cube_list_array(stamp.sec, stamp.nanosec, cloud.header.frame_id, layer.name, xyz,
                           rgba, size_m)


def fleet_map_markers(cloud, settings: Mapping[str, Any]) -> bytes:
    """Turn mlmap_fleet's merged map (PointCloud2 with `rgb`) into a serialised MarkerArray.

    One cube list (namespace 'fleet_map') coloured per vehicle by the cloud's rgb field; the
    cube edge is map_cube_size_m or, when that is 0, the voxel edge found in the cloud; thinned
    evenly to max_cubes as the other layers.
    """
    xyz, rgba = packed_rgb_colors(cloud)
    size_m = float(settings['map_cube_size_m'])
    if size_m <= 0:
        size_m = grid_spacing(xyz) or DEFAULT_VOXEL_EDGE_M
    keep = thin_evenly(len(xyz), int(settings['max_cubes']))
    stamp = cloud.header.stamp
    return cube_list_array(stamp.sec, stamp.nanosec, cloud.header.frame_id, 'fleet_map',
                           xyz[keep], rgba[keep], size_m)
