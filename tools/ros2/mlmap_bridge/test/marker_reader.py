"""Reads a serialised visualization_msgs/MarkerArray back, value by value (tests only).

The slow counterpart of mlmap_bridge/marker_cdr.py: struct.unpack_from at an explicit offset for
every value, one Python object per point. The byte layout itself is checked against an
independent CDR implementation by tests/ros2/marker_cdr_check.mjs.
"""

import struct
from types import SimpleNamespace


class _Reader:
    """Reads aligned little-endian CDR primitives after the 4-byte encapsulation header."""

    def __init__(self, data: bytes):
        assert data[:4] == b'\x00\x01\x00\x00', f'encapsulation {data[:4]!r} is not CDR_LE'
        self.data, self.offset = data, 4

    def read(self, code: str):
        size = struct.calcsize('<' + code)
        self.offset += -(self.offset - 4) % size
        (value,) = struct.unpack_from('<' + code, self.data, self.offset)
        self.offset += size
        return value

    def string(self) -> str:
        length = self.read('I')
        raw = self.data[self.offset:self.offset + length]
        assert length >= 1 and raw[-1:] == b'\x00', 'string without its NUL'
        self.offset += length
        return raw[:-1].decode('utf-8')

    def header(self) -> SimpleNamespace:
        stamp = SimpleNamespace(sec=self.read('i'), nanosec=self.read('I'))
        return SimpleNamespace(stamp=stamp, frame_id=self.string())


def _marker(r: _Reader) -> SimpleNamespace:
    m = SimpleNamespace(header=r.header(), ns=r.string(), id=r.read('i'), type=r.read('i'),
                        action=r.read('i'))
    position = SimpleNamespace(x=r.read('d'), y=r.read('d'), z=r.read('d'))
    orientation = SimpleNamespace(x=r.read('d'), y=r.read('d'), z=r.read('d'), w=r.read('d'))
    m.pose = SimpleNamespace(position=position, orientation=orientation)
    m.scale = SimpleNamespace(x=r.read('d'), y=r.read('d'), z=r.read('d'))
    m.color = SimpleNamespace(r=r.read('f'), g=r.read('f'), b=r.read('f'), a=r.read('f'))
    m.lifetime = SimpleNamespace(sec=r.read('i'), nanosec=r.read('I'))
    m.frame_locked = r.read('?')
    m.points = [SimpleNamespace(x=r.read('d'), y=r.read('d'), z=r.read('d'))
                for _ in range(r.read('I'))]
    m.colors = [SimpleNamespace(r=r.read('f'), g=r.read('f'), b=r.read('f'), a=r.read('f'))
                for _ in range(r.read('I'))]
    m.texture_resource = r.string()
    m.texture = SimpleNamespace(header=r.header(), format=r.string(),
                                data=[r.read('B') for _ in range(r.read('I'))])
    m.uv_coordinates = [(r.read('f'), r.read('f')) for _ in range(r.read('I'))]
    m.text = r.string()
    m.mesh_resource = r.string()
    m.mesh_file = SimpleNamespace(filename=r.string(),
                                  data=[r.read('B') for _ in range(r.read('I'))])
    m.mesh_use_embedded_materials = r.read('?')
    return m


def read_marker_array(data: bytes) -> SimpleNamespace:
    """Decode a MarkerArray; asserts that every byte is used."""
    r = _Reader(data)
    markers = [_marker(r) for _ in range(r.read('I'))]
    assert r.offset == len(data), f'{len(data) - r.offset} bytes left after the MarkerArray'
    return SimpleNamespace(markers=markers)
