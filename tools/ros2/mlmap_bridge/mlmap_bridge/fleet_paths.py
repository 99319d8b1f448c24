"""Each vehicle's path in its own colour, from the /tf the vehicles' nodes publish (no rclpy).

A vehicle's mlmap_node, with dds.frame_prefix set to its name, publishes world -> <name>/<body>
for each mapped frame; the bridge hands every transform to FleetPaths, which keeps one path per
vehicle (a point per `min_step_m` moved, at most `max_points`, the oldest dropped) and builds one
LINE_STRIP marker per vehicle in the colour mlmap_fleet gives it: the vehicle's position in
FleetStatus.vehicles (the merger's order) picks the palette entry, as it does for the merged
map's `rgb`; a vehicle the status has not listed yet takes the next free one.
"""

import math
from typing import Dict, List, Sequence, Tuple

from .marker_cdr import ADD

LINE_STRIP = 4

# mlmap_fleet's vehicle colours, 0xRRGGBB by vehicle index (fleet::vehicleColourRgb).
FLEET_PALETTE = (0xe6194b, 0x3cb44b, 0x4363d8, 0xf58231, 0x911eb4, 0x46f0f0, 0xf032e6, 0xbcf60c)


def vehicle_rgba(index: int) -> Tuple[float, float, float, float]:
    """Return the colour of vehicle `index` as RGBA in [0, 1] (opaque)."""
    rgb = FLEET_PALETTE[max(index, 0) % len(FLEET_PALETTE)]
    return ((rgb >> 16 & 0xff) / 255.0, (rgb >> 8 & 0xff) / 255.0, (rgb & 0xff) / 255.0, 1.0)


class FleetPaths:
    """The vehicles' paths, by vehicle name (the frame prefix of their body frame)."""

    def __init__(self, body_frame: str, min_step_m: float = 0.1, max_points: int = 5000):
        """Follow frames named <vehicle>/<body_frame>; keep a point per min_step_m moved."""
        self._suffix = '/' + body_frame.strip('/')
        self._min_step_m = float(min_step_m)
        self._max_points = int(max_points)
        self._paths: Dict[str, List[Tuple[float, float, float]]] = {}
        self._order: List[str] = []  # colour order: the merger's, then first seen

    def set_vehicles(self, names: Sequence[str]) -> None:
        """Take the merger's vehicle order (FleetStatus.vehicles) for the colours."""
        known = list(names)
        self._order = known + [n for n in self._order if n not in known]

    def add(self, child_frame_id: str, x: float, y: float, z: float) -> bool:
        """Add a transform's position if its child frame is a vehicle's body; True if added."""
        frame = child_frame_id.lstrip('/')
        if not frame.endswith(self._suffix) or len(frame) == len(self._suffix):
            return False
        vehicle = frame[:-len(self._suffix)]
        path = self._paths.setdefault(vehicle, [])
        if vehicle not in self._order:
            self._order.append(vehicle)
        if path and math.dist(path[-1], (x, y, z)) < self._min_step_m:
            return False
        path.append((float(x), float(y), float(z)))
        if len(path) > self._max_points:
            del path[0]
        return True

    def vehicles(self) -> List[str]:
        """Return the vehicle names with a path, in colour order."""
        return [n for n in self._order if n in self._paths]

    def colour_index(self, vehicle: str) -> int:
        """Return the palette index of a vehicle."""
        return self._order.index(vehicle)

    def path(self, vehicle: str) -> List[Tuple[float, float, float]]:
        """Return the positions kept for a vehicle, oldest first."""
        return list(self._paths.get(vehicle, []))

    def markers(self, types, frame_id: str, width_m: float = 0.08):
        """One LINE_STRIP per vehicle with two or more points (namespace 'fleet_paths').

        `types` holds the message classes (markers.MessageTypes, with Point).
        """
        array = types.MarkerArray()
        out = []
        for vehicle in self.vehicles():
            path = self._paths[vehicle]
            if len(path) < 2:
                continue
            marker = types.Marker()
            header = types.Header()
            header.frame_id = frame_id
            marker.header = header
            marker.ns = 'fleet_paths'
            marker.id = self.colour_index(vehicle)
            marker.type = LINE_STRIP
            marker.action = ADD
            marker.pose.orientation.w = 1.0
            marker.scale.x = float(width_m)
            r, g, b, a = vehicle_rgba(self.colour_index(vehicle))
            marker.color.r, marker.color.g, marker.color.b, marker.color.a = r, g, b, a
            points = []
            for x, y, z in path:
                p = types.Point()
                p.x, p.y, p.z = x, y, z
                points.append(p)
            marker.points = points
            out.append(marker)
        array.markers = out
        return array
