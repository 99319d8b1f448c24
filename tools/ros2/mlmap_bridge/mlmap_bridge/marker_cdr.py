"""A visualization_msgs/MarkerArray of one cube list, serialised as CDR from numpy arrays.

rclpy builds a Marker's `points` and `colors` as one Python object per element (a
geometry_msgs/Point and a std_msgs/ColorRGBA): for 100k voxels that is 200k objects and most of
the bridge's time. rclpy's `Publisher.publish()` also takes the serialised message as bytes
(`publish_raw`, since Humble), so the bridge writes the message itself: the fixed fields one by
one, the points as one float64 block and the colours as one float32 block straight from numpy.

The layout is Jazzy's visualization_msgs/msg/Marker (texture, uv_coordinates and mesh_file
included) in plain CDR, little endian, with the 4-byte encapsulation header (CDR_LE) that rmw
layers put in front of a serialised message; alignment counts from after that header.
`tests/ros2/marker_cdr_check.mjs` checks the bytes against an independent CDR implementation.
"""

import struct
from typing import List

import numpy as np

# visualization_msgs/Marker constants.
CUBE_LIST = 6
TEXT_VIEW_FACING = 9
ADD = 0
DELETE = 2

ENCAPSULATION_CDR_LE = b'\x00\x01\x00\x00'


class CdrWriter:
    """Appends CDR primitives, aligning each to its size from the start of the body."""

    def __init__(self):
        """Start an empty body (the encapsulation header is added by bytes())."""
        self._chunks: List[bytes] = []
        self._size = 0

    def _append(self, data: bytes) -> None:
        self._chunks.append(data)
        self._size += len(data)

    def align(self, alignment: int) -> None:
        """Pad with zero bytes to a multiple of alignment."""
        padding = -self._size % alignment
        if padding:
            self._append(b'\x00' * padding)

    def pack(self, fmt: str, *values) -> None:
        """Append values of one primitive struct format (all of the same size), aligned."""
        size = struct.calcsize('<' + fmt[0])
        self.align(size)
        self._append(struct.pack('<' + fmt, *values))

    def string(self, text: str) -> None:
        """Append a string: its length with the terminating NUL, the UTF-8 bytes, the NUL."""
        data = text.encode('utf-8') + b'\x00'
        self.pack('I', len(data))
        self._append(data)

    def array(self, values: np.ndarray, dtype: str) -> None:
        """Append a sequence of fixed-size elements: its element count, then the values.

        values has one row per element (a point's x, y, z; a colour's r, g, b, a); an empty
        sequence gets no alignment for its (absent) elements.
        """
        block = np.ascontiguousarray(values, dtype=np.dtype(dtype).newbyteorder('<'))
        self.pack('I', len(block))
        if len(block):
            self.align(block.dtype.itemsize)
            self._append(block.tobytes())

    def __bytes__(self) -> bytes:
        """Return the encapsulation header and the body."""
        return ENCAPSULATION_CDR_LE + b''.join(self._chunks)


def _header(writer: CdrWriter, sec: int, nanosec: int, frame_id: str) -> None:
    writer.pack('iI', sec, nanosec)
    writer.string(frame_id)


def cube_list_array(sec: int, nanosec: int, frame_id: str, ns: str, xyz: np.ndarray,
                    rgba: np.ndarray, size_m: float) -> bytes:
    """Serialise a MarkerArray holding one CUBE_LIST marker (id 0 of namespace ns).

    Each row of xyz (float64, shape (N, 3)) is a cube centre and the same row of rgba (shape
    (N, 4), in [0, 1]) its colour; size_m is the cube edge. An empty xyz gives a DELETE of that
    marker, so RViz drops what it showed before. The stamp and frame are the cloud's.
    """
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    rgba = np.asarray(rgba, dtype=np.float64).reshape(-1, 4)
    if len(xyz) != len(rgba):
        raise ValueError(f'{len(xyz)} points but {len(rgba)} colours')
    delete = len(xyz) == 0
    if not delete and not size_m > 0:
        raise ValueError(f'cube size must be positive, got {size_m}')
    edge = 0.0 if delete else float(size_m)
    writer = CdrWriter()
    writer.pack('I', 1)                                   # MarkerArray.markers: one marker
    _header(writer, int(sec), int(nanosec), frame_id)     # header
    writer.string(ns)                                     # ns
    writer.pack('iii', 0, 0 if delete else CUBE_LIST, DELETE if delete else ADD)  # id type action
    writer.pack('ddddddd', 0, 0, 0, 0, 0, 0, 1)            # pose: origin, identity
    writer.pack('ddd', edge, edge, edge)                  # scale
    writer.pack('ffff', *((0.0,) * 4 if delete else (1.0,) * 4))  # color (per point below)
    writer.pack('iI', 0, 0)                               # lifetime: forever
    writer.pack('?', False)                               # frame_locked
    writer.array(xyz, 'f8')                               # points
    writer.array(rgba, 'f4')                              # colors
    writer.string('')                                     # texture_resource
    _header(writer, 0, 0, '')                             # texture: CompressedImage header
    writer.string('')                                     # texture.format
    writer.pack('I', 0)                                   # texture.data
    writer.pack('I', 0)                                   # uv_coordinates
    writer.string('')                                     # text
    writer.string('')                                     # mesh_resource
    writer.string('')                                     # mesh_file.filename
    writer.pack('I', 0)                                   # mesh_file.data
    writer.pack('?', False)                               # mesh_use_embedded_materials
    return bytes(writer)
