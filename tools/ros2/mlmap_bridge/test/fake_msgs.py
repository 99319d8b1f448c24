"""Strict stand-ins for the ROS 2 message classes the bridge fills (tests only).

Like rclpy's generated classes they accept only their own field names and check each value's
Python type on assignment (a numpy float32 is not a float, a float is not an int), so a test
that fills these would also fill the real messages.
"""

from typing import Any, Dict


class Strict:
    """Base: fields declared in FIELDS as name -> float, int, str, bool, (list, T) or a class."""

    FIELDS: Dict[str, Any] = {}

    def __init__(self, **values):
        """Set every field to its default (0, '', [], nested default), then the given values."""
        for name, kind in self.FIELDS.items():
            object.__setattr__(self, name, [] if isinstance(kind, tuple) else kind())
        for name, value in values.items():
            setattr(self, name, value)

    def __setattr__(self, name, value):
        """Refuse unknown fields and values of the wrong Python type, as rclpy does."""
        if name not in self.FIELDS:
            raise AttributeError(f'{type(self).__name__} has no field {name!r}')
        kind = self.FIELDS[name]
        if isinstance(kind, tuple):
            assert isinstance(value, list) and all(isinstance(v, kind[1]) for v in value), \
                f'{name}: expected a list of {kind[1].__name__}'
        elif kind is float:
            assert isinstance(value, float), f'{name}: {type(value).__name__} is not a float'
        elif kind is int:
            assert isinstance(value, int) and not isinstance(value, bool), f'{name}: not an int'
        else:
            assert isinstance(value, kind), f'{name}: {type(value).__name__} is not {kind}'
        object.__setattr__(self, name, value)


class Time(Strict):
    """builtin_interfaces/Time."""

    FIELDS = {'sec': int, 'nanosec': int}


class Header(Strict):
    """std_msgs/Header."""

    FIELDS = {'stamp': Time, 'frame_id': str}


class Point(Strict):
    """geometry_msgs/Point."""

    FIELDS = {'x': float, 'y': float, 'z': float}


class Vector3(Strict):
    """geometry_msgs/Vector3."""

    FIELDS = {'x': float, 'y': float, 'z': float}


class Quaternion(Strict):
    """geometry_msgs/Quaternion."""

    FIELDS = {'x': float, 'y': float, 'z': float, 'w': float}


class Pose(Strict):
    """geometry_msgs/Pose."""

    FIELDS = {'position': Point, 'orientation': Quaternion}


class ColorRGBA(Strict):
    """std_msgs/ColorRGBA."""

    FIELDS = {'r': float, 'g': float, 'b': float, 'a': float}


class Marker(Strict):
    """visualization_msgs/Marker (the fields the bridge uses)."""

    FIELDS = {'header': Header, 'ns': str, 'id': int, 'type': int, 'action': int, 'pose': Pose,
              'scale': Vector3, 'color': ColorRGBA, 'frame_locked': bool,
              'points': (list, Point), 'colors': (list, ColorRGBA), 'text': str}


class MarkerArray(Strict):
    """visualization_msgs/MarkerArray."""

    FIELDS = {'markers': (list, Marker)}
