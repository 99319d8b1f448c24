"""markers.py: the RViz messages the bridge publishes, filled into strict message stand-ins."""

from cloud_helpers import field, FLOAT32, FLOAT64, make_cloud
import fake_msgs
from mlmap_bridge import conversions as cv
from mlmap_bridge import markers as mk
from mlmap_bridge import marker_cdr
from mlmap_bridge.parameters import CLOUD_LAYERS, defaults
from marker_reader import read_marker_array
import numpy as np
import pytest
import struct

TYPES = mk.MessageTypes(Marker=fake_msgs.Marker, MarkerArray=fake_msgs.MarkerArray,
                        Header=fake_msgs.Header)
LAYERS = {layer.name: layer for layer in CLOUD_LAYERS}
XYZ = [field('x', 0, FLOAT32), field('y', 4, FLOAT32), field('z', 8, FLOAT32)]


def _voxel_cloud(edge=0.2, count=50, seed=0, intensity=False):
    """Float32 voxel centres of a random blob, with a distance per voxel when asked."""
    rng = np.random.default_rng(seed)
    index = rng.integers(-20, 20, (count, 3))
    index[1] = index[0] + [1, 0, 0]
    centres = ((index + 0.5) * edge).astype(np.float32)
    fields = XYZ + ([field('intensity', 12, FLOAT32)] if intensity else [])
    points = [{'x': float(x), 'y': float(y), 'z': float(z),
               'intensity': float(rng.uniform(-1.0, 3.0))} for x, y, z in centres]
    cloud = make_cloud(points, fields, 16 if intensity else 12)
    cloud.header.stamp = fake_msgs.Time(sec=12, nanosec=345)
    return cloud


def _marker(data):
    """The one marker of a serialised MarkerArray, read back value by value."""
    assert isinstance(data, bytes)
    array = read_marker_array(data)
    assert len(array.markers) == 1
    return array.markers[0]


def test_height_layer_gives_one_cube_per_voxel_coloured_by_height():
    """Cubes at the voxel centres, colours of height_colors, edge found in the cloud."""
    cloud = _voxel_cloud(edge=0.15)
    settings = defaults()
    m = _marker(mk.cloud_layer_markers(LAYERS['local_map'], cloud, settings))
    xyz = cv.cloud_xyz(cloud)
    assert m.type == marker_cdr.CUBE_LIST and m.action == marker_cdr.ADD
    assert m.ns == 'local_map' and m.id == 0
    assert m.header.frame_id == cloud.header.frame_id == 'map'
    assert (m.header.stamp.sec, m.header.stamp.nanosec) == (12, 345)
    assert [(p.x, p.y, p.z) for p in m.points] == [tuple(p) for p in xyz.tolist()]
    expected = cv.height_colors(xyz[:, 2], settings['height_min_m'], settings['height_max_m'])
    assert [(c.r, c.g, c.b, c.a) for c in m.colors] == [
        tuple(c) for c in expected.astype(np.float32).tolist()]
    assert (m.scale.x, m.scale.y, m.scale.z) == pytest.approx((0.15, 0.15, 0.15), abs=1e-5)
    assert m.pose.orientation.w == 1.0


def test_distance_layer_is_coloured_by_the_intensity_field():
    """The ESDF slice: colours of distance_colors on the intensity (the distance) field."""
    cloud = _voxel_cloud(intensity=True)
    settings = dict(defaults(), esdf_max_distance_m=1.5)
    m = _marker(mk.cloud_layer_markers(LAYERS['esdf_slice'], cloud, settings))
    fields = cv.read_cloud_fields(cloud, ('x', 'y', 'z', 'intensity'))
    expected = cv.distance_colors(fields[:, 3], 1.5).astype(np.float32)
    assert [(c.r, c.g, c.b, c.a) for c in m.colors] == [tuple(c) for c in expected.tolist()]
    assert len(m.points) == len(fields)


def test_cube_size_parameter_wins_over_the_estimate():
    """A positive size parameter is used as is; the awareness layer has its own."""
    cloud = _voxel_cloud(edge=0.2)
    m = _marker(mk.cloud_layer_markers(LAYERS['global_map'], cloud,
                                       dict(defaults(), map_cube_size_m=0.33)))
    assert m.scale.x == 0.33
    m = _marker(mk.cloud_layer_markers(LAYERS['awareness'], cloud, defaults()))
    assert m.scale.x == defaults()['awareness_cube_size_m']


def test_a_single_voxel_gets_the_default_edge():
    """No two distinct coordinates: mlmap's default voxel edge."""
    cloud = make_cloud([{'x': 0.1, 'y': 0.1, 'z': 0.1}], XYZ, 12)
    m = _marker(mk.cloud_layer_markers(LAYERS['local_map'], cloud, defaults()))
    assert m.scale.x == mk.DEFAULT_VOXEL_EDGE_M and len(m.points) == 1


def test_large_clouds_are_thinned_with_the_edge_of_the_whole_cloud():
    """max_cubes bounds the marker; the cube edge still comes from all voxels."""
    cloud = _voxel_cloud(edge=0.1, count=500)
    m = _marker(mk.cloud_layer_markers(LAYERS['local_map'], cloud,
                                       dict(defaults(), max_cubes=40)))
    assert len(m.points) == len(m.colors) == 40
    assert m.scale.x == pytest.approx(0.1, abs=1e-5)


def test_empty_cloud_deletes_the_marker():
    """Nothing occupied any more: RViz must drop the old cubes."""
    cloud = make_cloud([], XYZ, 12, width=0)
    m = _marker(mk.cloud_layer_markers(LAYERS['local_map'], cloud, defaults()))
    assert m.action == marker_cdr.DELETE and m.ns == 'local_map' and m.points == []


def test_float64_big_endian_clouds_too():
    """The bridge reads any layout, not only mlmap_node's."""
    fields = [field('z', 0, FLOAT64), field('x', 8, FLOAT64), field('y', 16, FLOAT64)]
    cloud = make_cloud([{'x': 0.5, 'y': 1.5, 'z': 2.5}, {'x': 0.5, 'y': 1.5, 'z': 2.7}],
                       fields, 24, big_endian=True)
    m = _marker(mk.cloud_layer_markers(LAYERS['local_map'], cloud, defaults()))
    assert [(p.x, p.y, p.z) for p in m.points] == [(0.5, 1.5, 2.5), (0.5, 1.5, 2.7)]


def test_cube_list_checks_its_inputs():
    """Mismatched colours or a non-positive size are errors, not broken markers."""
    with pytest.raises(ValueError):
        marker_cdr.cube_list_array(0, 0, 'map', 'a', np.zeros((2, 3)), np.zeros((1, 4)), 0.1)
    with pytest.raises(ValueError):
        marker_cdr.cube_list_array(0, 0, 'map', 'a', np.zeros((2, 3)), np.zeros((2, 4)), 0.0)
    with pytest.raises(ValueError):
        mk.cloud_layer_markers(mk.CloudLayer('x', False, 'rainbow', 'max_cubes'),
                               _voxel_cloud(), defaults())


def test_text_marker_floats_above_the_body_frame():
    """A view-facing text at the body frame, offset up, with a zero stamp (latest TF)."""
    m = mk.text_marker(TYPES, 'base_link', 'status', 'hello\nworld', 0.25, 1.5)
    assert m.type == marker_cdr.TEXT_VIEW_FACING and m.action == marker_cdr.ADD
    assert m.text == 'hello\nworld'
    assert m.header.frame_id == 'base_link' and m.header.stamp.sec == 0
    assert m.pose.position.z == 1.5 and m.pose.orientation.w == 1.0 and m.scale.z == 0.25
    assert m.color.a == 1.0
    array = mk.marker_array(TYPES, m)
    assert array.markers == [m]


def test_fleet_map_cubes_take_each_voxels_vehicle_colour():
    """mlmap_fleet's cloud: the packed float32 rgb of each voxel becomes its cube's colour."""
    palette = [0xe6194b, 0x3cb44b, 0x4363d8]  # mlmap_fleet's first three vehicles
    rgb_as_float = [struct.unpack('<f', struct.pack('<I', c))[0] for c in palette]
    points = [{'x': 0.05 + 0.1 * i, 'y': 0.05, 'z': 1.05, 'rgb': rgb_as_float[i % 3]}
              for i in range(9)]
    fields = XYZ + [field('rgb', 12, FLOAT32)]
    cloud = make_cloud(points, fields, 16)
    cloud.header.stamp = fake_msgs.Time(sec=3, nanosec=4)
    m = _marker(mk.fleet_map_markers(cloud, defaults()))
    assert m.ns == 'fleet_map' and m.type == marker_cdr.CUBE_LIST
    expected = [((c >> 16 & 0xff) / 255.0, (c >> 8 & 0xff) / 255.0, (c & 0xff) / 255.0, 1.0)
                for c in palette] * 3
    colours = np.array([(c.r, c.g, c.b, c.a) for c in m.colors])
    assert colours.shape == (9, 4) and np.allclose(colours, expected, atol=1e-6)
    assert m.scale.x == pytest.approx(0.1, abs=1e-6)  # the voxel edge found in the cloud
    # An integer rgb field gives the same colours.
    as_int = make_cloud([dict(p, rgb=palette[i % 3]) for i, p in enumerate(points)],
                        XYZ + [field('rgb', 12, 6)], 16)
    xyz, rgba = cv.packed_rgb_colors(as_int)
    assert np.allclose(rgba, expected, atol=1e-9) and len(xyz) == 9
