"""Builds PointCloud2-like objects byte by byte for the tests, and reads them back slowly.

make_cloud writes each value with struct.pack at its own offset, the obviously correct way;
reference_fields reads them back with struct.unpack_from, point by point. The fast numpy
decoder in conversions.py is compared with both.
"""

import random
import struct
from types import SimpleNamespace
from typing import Dict, List, Sequence, Tuple

from fake_msgs import Header

# PointField datatype -> (struct code, size)
STRUCT = {1: ('b', 1), 2: ('B', 1), 3: ('h', 2), 4: ('H', 2), 5: ('i', 4), 6: ('I', 4),
          7: ('f', 4), 8: ('d', 8)}
FLOAT32, FLOAT64 = 7, 8


def field(name: str, offset: int, datatype: int, count: int = 1) -> SimpleNamespace:
    """Make a sensor_msgs/PointField."""
    return SimpleNamespace(name=name, offset=offset, datatype=datatype, count=count)


def make_cloud(points: Sequence[Dict[str, float]], fields: List[SimpleNamespace],
               point_step: int, width: int = None, height: int = 1, row_pad: int = 0,
               big_endian: bool = False, frame_id: str = 'map') -> SimpleNamespace:
    """Pack points (dicts of field values) into a PointCloud2-like object.

    width * height must equal len(points); rows are row_pad bytes longer than needed; bytes
    not covered by a field are filled with a recognisable pattern.
    """
    width = len(points) // height if width is None else width
    assert width * height == len(points)
    row_step = width * point_step + row_pad
    data = bytearray(b'\xa5' * (row_step * height))
    order = '>' if big_endian else '<'
    for i, values in enumerate(points):
        base = (i // width) * row_step + (i % width) * point_step
        for f in fields:
            code, _ = STRUCT[f.datatype]
            struct.pack_into(order + code, data, base + f.offset, values[f.name])
    return SimpleNamespace(header=Header(frame_id=frame_id), height=height, width=width,
                           fields=fields, is_bigendian=big_endian, point_step=point_step,
                           row_step=row_step, data=bytes(data), is_dense=False)


def reference_fields(cloud, names: Sequence[str]) -> List[Tuple[float, ...]]:
    """Read the named fields point by point with struct; skip points with a non-finite one."""
    order = '>' if cloud.is_bigendian else '<'
    by_name = {f.name: f for f in cloud.fields}
    out = []
    for row in range(cloud.height):
        for col in range(cloud.width):
            base = row * cloud.row_step + col * cloud.point_step
            values = []
            for name in names:
                f = by_name[name]
                code, _ = STRUCT[f.datatype]
                values.append(float(struct.unpack_from(order + code, cloud.data,
                                                       base + f.offset)[0]))
            if all(v == v and abs(v) != float('inf') for v in values):
                out.append(tuple(values))
    return out


def random_layout(rng: random.Random, extra: Sequence[Tuple[str, int]] = ()):
    """Random field order, float32/float64 x, y, z, extra fields and padding between them.

    Returns (fields, point_step). Offsets are aligned to each field's size or not, at random.
    """
    specs = [(axis, rng.choice([FLOAT32, FLOAT64])) for axis in 'xyz'] + list(extra)
    rng.shuffle(specs)
    fields, offset = [], rng.choice([0, 0, 1, 4])
    for name, datatype in specs:
        size = STRUCT[datatype][1]
        if rng.random() < 0.5:
            offset += (-offset) % size   # aligned
        fields.append(field(name, offset, datatype))
        offset += size + rng.choice([0, 0, 1, 3, 8])
    return fields, offset + rng.choice([0, 2, 16])


def value_for(datatype: int, rng: random.Random) -> float:
    """Draw a random value that the datatype holds exactly."""
    code, size = STRUCT[datatype]
    if code in 'fd':
        return struct.unpack(code, struct.pack(code, rng.uniform(-50.0, 50.0)))[0]
    bits = 8 * size
    low, high = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if code.islower() else \
        (0, (1 << bits) - 1)
    return rng.randint(low, high)
