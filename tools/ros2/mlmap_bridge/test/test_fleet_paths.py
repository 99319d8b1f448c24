"""fleet_paths.py: each vehicle's path from /tf, in mlmap_fleet's colour for that vehicle."""

import fake_msgs
from mlmap_bridge import markers as mk
from mlmap_bridge.fleet_paths import FleetPaths, LINE_STRIP, vehicle_rgba
import pytest

TYPES = mk.MessageTypes(Marker=fake_msgs.Marker, MarkerArray=fake_msgs.MarkerArray,
                        Header=fake_msgs.Header, Point=fake_msgs.Point)


def test_paths_follow_each_vehicles_body_frame_and_skip_other_frames():
    """uav1/base_link and uav2/base_link make two paths; other frames and small moves do not."""
    paths = FleetPaths('base_link', min_step_m=0.1)
    assert paths.add('uav1/base_link', 0.0, 0.0, 1.0)
    assert paths.add('uav2/base_link', 5.0, 0.0, 1.0)
    assert not paths.add('base_link', 1.0, 1.0, 1.0)        # no prefix: not a fleet vehicle
    assert not paths.add('uav1/camera', 1.0, 1.0, 1.0)      # not the body
    assert not paths.add('uav1/base_link', 0.05, 0.0, 1.0)  # moved less than min_step_m
    assert paths.add('/uav1/base_link', 0.2, 0.0, 1.0)
    assert paths.vehicles() == ['uav1', 'uav2']
    assert paths.path('uav1') == [(0.0, 0.0, 1.0), (0.2, 0.0, 1.0)]


def test_colours_follow_the_mergers_vehicle_order():
    """FleetStatus.vehicles decides the palette index, as for the merged map's rgb."""
    paths = FleetPaths('base_link')
    for x in (0.0, 1.0):
        paths.add('uav1/base_link', x, 0.0, 1.0)
        paths.add('uav2/base_link', x, 2.0, 1.0)
    paths.set_vehicles(['uav2', 'uav1'])  # the merger heard uav2 first
    array = paths.markers(TYPES, 'map')
    by_ns_id = {(m.ns, m.id): m for m in array.markers}
    assert set(by_ns_id) == {('fleet_paths', 0), ('fleet_paths', 1)}
    uav2, uav1 = by_ns_id[('fleet_paths', 0)], by_ns_id[('fleet_paths', 1)]
    assert uav2.type == uav1.type == LINE_STRIP
    assert (uav2.color.r, uav2.color.g, uav2.color.b) == pytest.approx(vehicle_rgba(0)[:3])
    assert (uav1.color.r, uav1.color.g, uav1.color.b) == pytest.approx(vehicle_rgba(1)[:3])
    assert [(p.x, p.y, p.z) for p in uav1.points] == [(0.0, 0.0, 1.0), (1.0, 0.0, 1.0)]
    assert uav1.header.frame_id == 'map'


def test_a_path_keeps_its_newest_points():
    """At most max_points, the oldest dropped; a single point draws no line."""
    paths = FleetPaths('base_link', min_step_m=0.0, max_points=3)
    for x in range(5):
        paths.add('uav1/base_link', float(x), 0.0, 0.0)
    assert [p[0] for p in paths.path('uav1')] == [2.0, 3.0, 4.0]
    paths.add('uav2/base_link', 0.0, 0.0, 0.0)
    assert [m.id for m in paths.markers(TYPES, 'map').markers] == [0]
