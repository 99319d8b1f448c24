#!/usr/bin/python3
"""ROS 2 type hashes (REP-2011, RIHS01) of the DDS IDL files under idl/, for the build.

ROS 2 since Iron names every interface type by a hash of its type description: the type's
fields (name, field type id, array capacity, string bound, nested type name) and those of every
type it refers to, written as JSON in a fixed form and hashed with SHA-256. rmw puts the result
in each endpoint's USER_DATA as `typehash=RIHS01_<64 hex>;`. This tool computes the hashes the
way rosidl_generator_type_description does, from mlmap's DDS-form IDL (`module <pkg> { module msg
{ module dds_ { struct <Name>_ { <type> <member>_; ... }; }; }; };`): the `dds_` module and the
trailing underscores are dropped to get the ROS names back.

A file under `<pkg>/srv/` holds a service's `<Name>_Request_` and `<Name>_Response_` structs; the
service type `<pkg>/srv/<Name>` and its `<Name>_Event` (service_msgs/msg/ServiceEventInfo `info`,
at most one request and one response) are derived from them as rosidl does. Their table entries
use the DDS naming too (`<pkg>::srv::dds_::<Name>_`, `..._Event_`), though only _Request_ and
_Response_ go on the wire.

A member may carry the annotation `@key` (mlmap_msgs/Submap: a keyed topic among mlmap's own
participants); the type description has no notion of keys, so the hash is that of the same
struct without it, as rosidl computes it for the .msg twin.

The DDS form loses one distinction of the ROS form: `octet` is both ROS `uint8` (and `char`,
which rosidl maps to uint8) and ROS `byte`. It is read as uint8, what every standard type mlmap
uses has; a member whose ROS type is `byte` says so with the comment `// ros: byte` on its line.

Usage: idl_type_hashes.py --idl-root DIR --header OUT.h   (writes a C++ header with the table)
       idl_type_hashes.py --idl-root DIR --print           (prints `<dds type> <hash>` lines)
"""

import argparse
import hashlib
import json
from pathlib import Path
import re
import sys

# type_description_interfaces/msg/FieldType.msg: basic type ids; arrays add 48, bounded
# sequences 96, unbounded sequences 144.
FIELD_TYPE_IDS = {
    'nested': 1,
    'int8': 2, 'uint8': 3, 'int16': 4, 'uint16': 5, 'int32': 6, 'uint32': 7, 'int64': 8,
    'uint64': 9, 'float': 10, 'double': 11, 'long double': 12, 'char': 13, 'wchar': 14,
    'boolean': 15, 'byte': 16, 'string': 17, 'wstring': 18, 'bounded string': 21,
    'bounded wstring': 22,
}
ARRAY_OFFSET = 48
BOUNDED_SEQUENCE_OFFSET = 96
UNBOUNDED_SEQUENCE_OFFSET = 144

# DDS IDL basic types (as mlmap's IDL and rosidl_generator_dds_idl write them) -> ROS basic type.
IDL_BASIC_TYPES = {
    'boolean': 'boolean',
    'octet': 'uint8',
    'int8': 'int8',
    'uint8': 'uint8',
    'short': 'int16',
    'int16': 'int16',
    'unsigned short': 'uint16',
    'uint16': 'uint16',
    'long': 'int32',
    'int32': 'int32',
    'unsigned long': 'uint32',
    'uint32': 'uint32',
    'long long': 'int64',
    'int64': 'int64',
    'unsigned long long': 'uint64',
    'uint64': 'uint64',
    'float': 'float',
    'double': 'double',
    'long double': 'long double',
    'char': 'char',
    'wchar': 'wchar',
}

MODULE_RE = re.compile(r'module\s+(\w+)\s*\{\s*module\s+(msg|srv)\s*\{\s*module\s+dds_\s*\{')
STRUCT_RE = re.compile(r'struct\s+(\w+)_\s*\{(.*?)\};', re.S)
MEMBER_RE = re.compile(
    r'^\s*(?:@key\s+)?(?P<type>sequence\s*<\s*(?P<elem>[^,>]+?)\s*(?:,\s*(?P<bound>\d+)\s*)?>'
    r'|[A-Za-z_][\w:]*(?:\s+(?:long|short|double))*(?:\s*<\s*\d+\s*>)?)'
    r'\s+(?P<name>\w+)_\s*(?:\[\s*(?P<size>\d+)\s*\])?\s*;\s*(?://\s*(?P<comment>.*))?$')
STRING_RE = re.compile(r'^(w?string)(?:\s*<\s*(\d+)\s*>)?$')
NESTED_RE = re.compile(r'^(\w+)::(msg|srv)::dds_::(\w+)_$')


class IdlError(Exception):
    """An IDL file this tool cannot read."""


def value_type(idl_type, comment):
    """Return (basic type id key, string capacity, nested type name) of an IDL element type."""
    idl_type = ' '.join(idl_type.split())
    string = STRING_RE.match(idl_type)
    if string:
        kind, bound = string.group(1), string.group(2)
        if bound:
            return ('bounded ' + kind, int(bound), '')
        return (kind, 0, '')
    nested = NESTED_RE.match(idl_type)
    if nested:
        return ('nested', 0, '/'.join(nested.groups()))
    if idl_type not in IDL_BASIC_TYPES:
        raise IdlError(f'unknown IDL type {idl_type!r}')
    ros_type = IDL_BASIC_TYPES[idl_type]
    if idl_type == 'octet' and comment is not None and comment.strip().startswith('ros: byte'):
        ros_type = 'byte'
    return (ros_type, 0, '')


def field(line):
    """Return the type description field of a member line (its name, type, default value)."""
    match = MEMBER_RE.match(line)
    if not match:
        raise IdlError(f'cannot read the member {line.strip()!r}')
    comment = match.group('comment')
    if match.group('elem') is not None:
        basic, string_capacity, nested = value_type(match.group('elem'), comment)
        bound = match.group('bound')
        offset = BOUNDED_SEQUENCE_OFFSET if bound else UNBOUNDED_SEQUENCE_OFFSET
        capacity = int(bound) if bound else 0
    else:
        basic, string_capacity, nested = value_type(match.group('type'), comment)
        size = match.group('size')
        offset = ARRAY_OFFSET if size else 0
        capacity = int(size) if size else 0
    return {
        'name': match.group('name'),
        'type': {
            'type_id': FIELD_TYPE_IDS[basic] + offset,
            'capacity': capacity,
            'string_capacity': string_capacity,
            'nested_type_name': nested,
        },
        'default_value': '',
    }


def nested_field(name, type_name, offset=0, capacity=0):
    """Return a field of a nested type (offset: 0, or an array / sequence offset)."""
    return {
        'name': name,
        'type': {
            'type_id': FIELD_TYPE_IDS['nested'] + offset,
            'capacity': capacity,
            'string_capacity': 0,
            'nested_type_name': type_name,
        },
        'default_value': '',
    }


def add_service_types(types):
    """Add the service type and its _Event type of each _Request/_Response pair in `types`."""
    for request in [name for name in types if name.endswith('_Request')]:
        service = request[:-len('_Request')]
        response = service + '_Response'
        if response not in types:
            raise IdlError(f'{request} has no {response}')
        event = service + '_Event'
        types[event] = {'type_name': event, 'fields': [
            nested_field('info', 'service_msgs/msg/ServiceEventInfo'),
            nested_field('request', request, BOUNDED_SEQUENCE_OFFSET, 1),
            nested_field('response', response, BOUNDED_SEQUENCE_OFFSET, 1),
        ]}
        types[service] = {'type_name': service, 'fields': [
            nested_field('request_message', request),
            nested_field('response_message', response),
            nested_field('event_message', event),
        ]}


def strip_comments_and_directives(text):
    """Return the IDL text without block comments and preprocessor lines (line comments stay)."""
    text = re.sub(r'/\*.*?\*/', '', text, flags=re.S)
    return '\n'.join(line for line in text.splitlines() if not line.lstrip().startswith('#'))


def read_idl(path):
    """{ROS type name: individual type description} of the structs of one IDL file."""
    text = strip_comments_and_directives(path.read_text(encoding='utf-8'))
    module = MODULE_RE.search(text)
    if not module:
        raise IdlError(f'{path}: no `module <pkg> {{ module msg|srv {{ module dds_ {{`')
    package, kind = module.groups()
    types = {}
    for struct in STRUCT_RE.finditer(text[module.end():]):
        name, body = struct.groups()
        lines = [line for line in body.splitlines() if line.split('//')[0].strip()]
        type_name = f'{package}/{kind}/{name}'
        types[type_name] = {'type_name': type_name, 'fields': [field(line) for line in lines]}
    if not types:
        raise IdlError(f'{path}: no struct')
    if kind == 'srv':
        add_service_types(types)
    return types


def full_description(type_name, individual):
    """Return the type's description and, sorted by name, every type it refers to."""
    references = set()
    pending = [type_name]
    while pending:
        for f in individual[pending.pop()]['fields']:
            nested = f['type']['nested_type_name']
            if nested and nested not in references:
                if nested not in individual:
                    raise IdlError(f'{type_name} refers to {nested}, which no IDL file defines')
                references.add(nested)
                pending.append(nested)
    return {
        'type_description': individual[type_name],
        'referenced_type_descriptions': [individual[name] for name in sorted(references)],
    }


def type_hash(description):
    """RIHS01 of a full type description: default values left out, JSON as rosidl writes it."""
    hashable = json.loads(json.dumps(description))
    for individual in [hashable['type_description']] + hashable['referenced_type_descriptions']:
        for f in individual['fields']:
            del f['default_value']
    text = json.dumps(hashable, ensure_ascii=True, allow_nan=False, indent=None,
                      separators=(', ', ': '), sort_keys=False)
    return 'RIHS01_' + hashlib.sha256(text.encode('utf-8')).hexdigest()


def dds_type_name(type_name):
    """`pkg/msg/Name` -> `pkg::msg::dds_::Name_` (the name registered on the wire)."""
    package, kind, name = type_name.split('/')
    return f'{package}::{kind}::dds_::{name}_'


def hashes(idl_root):
    """[(DDS type name, hash)] of every struct under idl_root/<pkg>/<msg|srv>/*.idl, sorted."""
    individual = {}
    for path in sorted(idl_root.glob('*/*/*.idl')):
        individual.update(read_idl(path))
    return sorted((dds_type_name(name), type_hash(full_description(name, individual)))
                  for name in individual)


def header(table):
    """C++ header text with the table as constexpr data."""
    rows = '\n'.join(f'    {{"{name}", "{value}"}},' for name, value in table)
    return f"""// Generated at build time by tools/idl_type_hashes.py from idl/; do not edit.
#pragma once

namespace mlmap::dds::generated {{

/// One DDS type name and its ROS 2 type hash (REP-2011, RIHS01).
struct TypeHashEntry {{
  const char* dds_type;  ///< e.g. "std_msgs::msg::dds_::Header_"
  const char* hash;      ///< "RIHS01_" and 64 hex digits
}};

/// Every struct of idl/, sorted by DDS type name.
inline constexpr TypeHashEntry kTypeHashes[] = {{
{rows}
}};

}}  // namespace mlmap::dds::generated
"""


def main():
    """Compute the table and write it as a header or print it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--idl-root', type=Path, required=True)
    output = parser.add_mutually_exclusive_group(required=True)
    output.add_argument('--header', type=Path)
    output.add_argument('--print', action='store_true')
    args = parser.parse_args()
    try:
        table = hashes(args.idl_root)
    except IdlError as e:
        print(f'idl_type_hashes.py: {e}', file=sys.stderr)
        return 1
    if args.print:
        for name, value in table:
            print(name, value)
        return 0
    text = header(table)
    if not args.header.exists() or args.header.read_text(encoding='utf-8') != text:
        args.header.parent.mkdir(parents=True, exist_ok=True)
        args.header.write_text(text, encoding='utf-8')
    return 0


if __name__ == '__main__':
    sys.exit(main())
