#!/usr/bin/python3
"""CDR layouts of the DDS IDL structs under idl/, as a C++ header for the build.

mlmap checks every received sample against its type's layout before Fast CDR deserialises it
(include/mlmap/dds/wire/cdr_check.h): Fast CDR 1.0 sizes a sequence from its declared count, so a
count the payload cannot hold must be refused first. The layout of a struct is its members in
wire order, each a number (its size), a string (its bound) or a nested struct, single, in a fixed
array or in a (bounded) sequence, and the least bytes one value takes on the wire; a struct of
numbers only (Time, Point, Transform) also has its fixed size and alignment, so a walk skips it
whole.

The IDL is read by tools/idl_type_hashes.py's parser (the same files, the same layout rules: see
its docstring and idl/README.md), so the two generated tables cannot disagree on a field. Only the
structs of the files are laid out: the service and _Event types that parser derives for REP-2011
never go on the wire. Types the layout has no rule for (wchar, wstring, long double) are refused.

Usage: idl_cdr_layouts.py --idl-root DIR --header OUT.h   (writes the C++ header)
       idl_cdr_layouts.py --idl-root DIR --types-header OUT.h   (the generated Fast DDS type of
                                                                 each struct, for tests)
       idl_cdr_layouts.py --idl-root DIR --print           (prints `<dds type> <min bytes> <fixed bytes>
                                                           <fixed alignment>` lines)
"""

import argparse
from pathlib import Path
import re
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree at build time
sys.path.insert(0, str(Path(__file__).resolve().parent))
import idl_type_hashes as idl  # noqa: E402  (the shared IDL parser)

# Basic type id (type_description_interfaces/FieldType) -> bytes of one value on the wire.
NUMBER_BYTES = {
    idl.FIELD_TYPE_IDS['int8']: 1, idl.FIELD_TYPE_IDS['uint8']: 1,
    idl.FIELD_TYPE_IDS['char']: 1, idl.FIELD_TYPE_IDS['byte']: 1,
    idl.FIELD_TYPE_IDS['boolean']: 1,
    idl.FIELD_TYPE_IDS['int16']: 2, idl.FIELD_TYPE_IDS['uint16']: 2,
    idl.FIELD_TYPE_IDS['int32']: 4, idl.FIELD_TYPE_IDS['uint32']: 4,
    idl.FIELD_TYPE_IDS['float']: 4,
    idl.FIELD_TYPE_IDS['int64']: 8, idl.FIELD_TYPE_IDS['uint64']: 8,
    idl.FIELD_TYPE_IDS['double']: 8,
}
STRING_IDS = {idl.FIELD_TYPE_IDS['string'], idl.FIELD_TYPE_IDS['bounded string']}
NESTED_ID = idl.FIELD_TYPE_IDS['nested']
CONTAINERS = {0: 'kSingle', idl.ARRAY_OFFSET: 'kArray',
              idl.BOUNDED_SEQUENCE_OFFSET: 'kSequence', idl.UNBOUNDED_SEQUENCE_OFFSET: 'kSequence'}
STRING_MIN_BYTES = 4  # its length; Fast CDR reads a length of 0 as an empty string


def wire_types(idl_root, files=None):
    """{ROS type name: fields} of every struct the IDL files declare (no derived service types);
    `files`, if given, gets {ROS type name: the IDL file's path under idl_root, without .idl}."""
    types = {}
    for path in sorted(idl_root.glob('*/*/*.idl')):
        for name, description in idl.read_idl(path).items():
            kind = name.split('/')[1]
            if kind == 'srv' and not name.endswith(('_Request', '_Response')):
                continue
            types[name] = description['fields']
            if files is not None:
                files[name] = path.relative_to(idl_root).with_suffix('').as_posix()
    return types


def member(field, layouts):
    """The layout of one field: a dict of CdrMemberLayout's values (nested types laid out)."""
    type_id = field['type']['type_id']
    basic = type_id % idl.ARRAY_OFFSET
    container = CONTAINERS[type_id - basic]
    capacity = field['type']['capacity']
    result = {'name': field['name'], 'container': container, 'count': capacity,
              'number_bytes': 0, 'string_bound': 0, 'type': None}
    if basic in NUMBER_BYTES:
        result['kind'] = 'kNumber'
        result['number_bytes'] = NUMBER_BYTES[basic]
        value_min = NUMBER_BYTES[basic]
    elif basic in STRING_IDS:
        result['kind'] = 'kString'
        result['string_bound'] = field['type']['string_capacity']
        value_min = STRING_MIN_BYTES
    elif basic == NESTED_ID:
        result['kind'] = 'kStruct'
        result['type'] = field['type']['nested_type_name']
        value_min = layouts[result['type']]['min_bytes']
    else:
        raise idl.IdlError(f'member {field["name"]}: no CDR layout rule for type id {type_id}')
    if container == 'kSingle':
        result['min_bytes'] = value_min
    elif container == 'kArray':
        result['min_bytes'] = value_min * capacity
    else:
        result['min_bytes'] = 4  # the count; no element needs to follow
    return result


def fixed_numbers(members, done):
    """[(bytes of a number, how many)] a struct is on the wire when it holds numbers only (in
    single members, arrays and nested structs of numbers only), in order; None otherwise."""
    numbers = []
    for m in members:
        times = m['count'] if m['container'] == 'kArray' else 1
        if m['container'] == 'kSequence' or m['kind'] == 'kString':
            return None
        if m['kind'] == 'kNumber':
            numbers.append((m['number_bytes'], times))
        else:
            nested = done[m['type']]['numbers']
            if nested is None:
                return None
            numbers.extend(nested * times)
    return numbers


def layouts(idl_root):
    """[(ROS type name, layout)] of every wire struct, each after the structs it nests."""
    types = wire_types(idl_root)
    done = {}
    order = []

    def visit(name, path):
        if name in done:
            return
        if name in path:
            raise idl.IdlError(f'{name} contains itself')
        if name not in types:
            raise idl.IdlError(f'{path[-1]} refers to {name}, which no IDL file defines')
        for f in types[name]:
            nested = f['type']['nested_type_name']
            if nested:
                visit(nested, path + [name])
        members = [member(f, done) for f in types[name]]
        numbers = fixed_numbers(members, done)
        fixed_bytes, fixed_align = 0, 1
        if numbers is not None:
            for size, count in numbers:
                fixed_bytes = (fixed_bytes + size - 1) // size * size + size * count
                fixed_align = max(fixed_align, size)
        done[name] = {'members': members, 'min_bytes': sum(m['min_bytes'] for m in members),
                      'fixed_bytes': fixed_bytes, 'fixed_align': fixed_align,
                      'numbers': numbers}
        order.append(name)

    for name in sorted(types):
        visit(name, [])
    return [(name, done[name]) for name in order]


def identifier(ros_name):
    """A C++ identifier part for a type: `tf2_msgs/msg/TFMessage` -> `Tf2MsgsMsgTFMessage`."""
    return ''.join(part[0].upper() + part[1:] for part in re.split(r'[/_]', ros_name) if part)


def header(table):
    """C++ header text with one constexpr layout per struct and the sorted table of them."""
    identifiers = {identifier(name) for name, _ in table}
    if len(identifiers) != len(table):
        raise idl.IdlError('two types give the same C++ identifier')
    blocks = []
    for name, layout in table:
        rows = []
        for m in layout['members']:
            nested = f'&kLayout{identifier(m["type"])}' if m['type'] else 'nullptr'
            rows.append(f'    {{"{m["name"]}", CdrValueKind::{m["kind"]}, {m["number_bytes"]}, '
                        f'CdrContainer::{m["container"]}, {m["count"]}, {m["string_bound"]}, '
                        f'{nested}}},')
        ident = identifier(name)
        blocks.append(
            f'inline constexpr CdrMemberLayout kMembers{ident}[] = {{\n' + '\n'.join(rows) + '\n};\n'
            f'inline constexpr CdrStructLayout kLayout{ident} = {{"{idl.dds_type_name(name)}", '
            f'kMembers{ident}, {len(layout["members"])}, {layout["min_bytes"]}, '
            f'{layout["fixed_bytes"]}, {layout["fixed_align"]}}};\n')
    sorted_names = sorted(table, key=lambda entry: idl.dds_type_name(entry[0]))
    index = '\n'.join(f'    &kLayout{identifier(name)},' for name, _ in sorted_names)
    return f"""// Generated at build time by tools/idl_cdr_layouts.py from idl/; do not edit.
#pragma once

#include "mlmap/dds/wire/cdr_check.h"

namespace mlmap::dds::generated {{

{chr(10).join(blocks)}
/// Every struct of idl/, sorted by DDS type name.
inline constexpr const CdrStructLayout* kCdrLayouts[] = {{
{index}
}};

}}  // namespace mlmap::dds::generated
"""


def types_header(idl_root):
    """C++ header text naming every wire struct's generated Fast DDS type (for tests)."""
    files = {}
    names = sorted(wire_types(idl_root, files), key=idl.dds_type_name)
    includes = '\n'.join(sorted({f'#include "{files[name]}PubSubTypes.h"' for name in names}))
    types = ',\n'.join(f'    ::{idl.dds_type_name(name)}PubSubType' for name in names)
    return f"""// Generated at build time by tools/idl_cdr_layouts.py from idl/; do not edit.
#pragma once

{includes}

#include <tuple>

namespace mlmap::dds::generated {{

/// The generated Fast DDS type of every struct of idl/, in the order of kCdrLayouts.
using IdlPubSubTypes = std::tuple<
{types}>;

}}  // namespace mlmap::dds::generated
"""


def write_if_changed(path, text):
    """Writes `text` to `path` unless it holds it already, whole (a parallel build never reads
    half a header)."""
    if not path.exists() or path.read_text(encoding='utf-8') != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + '.tmp')
        tmp.write_text(text, encoding='utf-8')
        tmp.replace(path)


def main():
    """Lay out the structs and write the header or print them."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--idl-root', type=Path, required=True)
    output = parser.add_mutually_exclusive_group(required=True)
    output.add_argument('--header', type=Path)
    output.add_argument('--types-header', type=Path,
                        help='write a header naming every struct\'s generated Fast DDS type instead')
    output.add_argument('--print', action='store_true')
    args = parser.parse_args()
    try:
        table = layouts(args.idl_root)
        if args.types_header:
            write_if_changed(args.types_header, types_header(args.idl_root))
            return 0
    except idl.IdlError as e:
        print(f'idl_cdr_layouts.py: {e}', file=sys.stderr)
        return 1
    if args.print:
        for name, layout in sorted(table, key=lambda entry: idl.dds_type_name(entry[0])):
            print(idl.dds_type_name(name), layout['min_bytes'], layout['fixed_bytes'],
                  layout['fixed_align'])
        return 0
    write_if_changed(args.header, header(table))
    return 0


if __name__ == '__main__':
    sys.exit(main())
