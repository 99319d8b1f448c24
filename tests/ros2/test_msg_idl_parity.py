"""Keeps mlmap's ROS 2 messages and its wire IDL in step.

mlmap_node (no ROS) puts `idl/mlmap_msgs/msg/<Name>_.idl` on the wire; ROS 2 nodes decode it with
the types that `tools/ros2/mlmap_msgs/msg/<Name>.msg` generates. Both must have the same fields
in the same order with the same types, or rclpy reads garbage. This test parses both with the
ROS 2 parsers (Debian's python3-rosidl: rosidl_adapter for .msg, rosidl_parser for IDL) and
fails on any difference. The comparison is done in the DDS IDL vocabulary that rmw uses
(`uint8` -> `octet`, `float64` -> `double`, `std_msgs/Header` -> `std_msgs::msg::dds_::Header_`).
"""

from pathlib import Path
import re
from typing import List, Tuple

import pytest
from rosidl_adapter.parser import parse_message_string
from rosidl_parser import definition
from rosidl_parser.parser import parse_idl_string

REPO = Path(__file__).resolve().parents[2]
IDL_ROOT = REPO / 'idl'
IDL_DIR = IDL_ROOT / 'mlmap_msgs' / 'msg'
MSG_PACKAGE = REPO / 'tools' / 'ros2' / 'mlmap_msgs'
MSG_DIR = MSG_PACKAGE / 'msg'
PACKAGE = 'mlmap_msgs'

# .msg primitive -> the IDL basic type rmw puts on the wire, as rosidl_parser names it.
# Only mappings checked against the repository's standard types are listed; anything else
# fails loudly so that a new type is looked at instead of compared wrongly.
MSG_TO_IDL_BASIC = {
    'bool': 'boolean',
    'byte': 'octet',
    'uint8': 'octet',
    'int8': 'int8',
    'int16': 'int16',
    'uint16': 'uint16',
    'int32': 'int32',
    'uint32': 'uint32',
    'int64': 'int64',
    'uint64': 'uint64',
    'float32': 'float',
    'float64': 'double',
}

Field = Tuple[str, str]  # (name, type in DDS IDL words)


def msg_fields(package: str, name: str, text: str) -> List[Field]:
    """Return the fields of a .msg text as (IDL member name, IDL type) pairs."""
    spec = parse_message_string(package, name, text)
    if spec.constants:
        raise AssertionError(f'{name}.msg has constants; extend this check to compare them')
    return [(field.name + '_', _msg_type_to_idl(field.type)) for field in spec.fields]


def _msg_type_to_idl(msg_type) -> str:
    """Spell a rosidl_adapter field type the way the DDS IDL spells it."""
    if msg_type.is_primitive_type():
        if msg_type.type == 'string':
            bound = msg_type.string_upper_bound
            element = 'string' if bound is None else f'string<{bound}>'
        elif msg_type.type in MSG_TO_IDL_BASIC:
            element = MSG_TO_IDL_BASIC[msg_type.type]
        else:
            raise AssertionError(f'.msg type {msg_type.type} has no checked IDL mapping')
    else:
        element = f'{msg_type.pkg_name}::msg::dds_::{msg_type.type}_'
    if not msg_type.is_array:
        return element
    if msg_type.array_size is None:
        return f'sequence<{element}>'
    if msg_type.is_upper_bound:
        return f'sequence<{element}, {msg_type.array_size}>'
    return f'{element}[{msg_type.array_size}]'


def strip_include_guard(text: str, where: str) -> str:
    """Remove the `#ifndef G / #define G / #endif` guard that fastddsgen needs.

    rosidl_parser reads #include but no other preprocessor line. Exactly one guard pair is
    accepted, with matching symbols; any other preprocessor line is an error.
    """
    kept, guard = [], []
    for line in text.splitlines():
        match = re.match(r'\s*#\s*(ifndef|define|endif)\b\s*(\S*)', line)
        if match:
            guard.append((match.group(1), match.group(2)))
            continue
        if re.match(r'\s*#', line) and not re.match(r'\s*#include\s+"[^"]+"\s*$', line):
            raise AssertionError(f'{where}: unexpected preprocessor line: {line}')
        kept.append(line)
    directives = [d for d, _ in guard]
    if directives != ['ifndef', 'define', 'endif'] or guard[0][1] != guard[1][1]:
        raise AssertionError(f'{where}: expected one include guard, found {guard}')
    return '\n'.join(kept) + '\n'


def _idl_type(idl_type) -> str:
    """Spell a rosidl_parser type in DDS IDL words."""
    if isinstance(idl_type, definition.BasicType):
        return idl_type.typename
    if isinstance(idl_type, definition.UnboundedString):
        return 'string'
    if isinstance(idl_type, definition.BoundedString):
        return f'string<{idl_type.maximum_size}>'
    if isinstance(idl_type, definition.NamespacedType):
        return '::'.join([str(n) for n in idl_type.namespaces] + [idl_type.name])
    if isinstance(idl_type, definition.UnboundedSequence):
        return f'sequence<{_idl_type(idl_type.value_type)}>'
    if isinstance(idl_type, definition.BoundedSequence):
        return f'sequence<{_idl_type(idl_type.value_type)}, {idl_type.maximum_size}>'
    if isinstance(idl_type, definition.Array):
        return f'{_idl_type(idl_type.value_type)}[{idl_type.size}]'
    raise AssertionError(f'IDL type {idl_type!r} is not handled by this check')


def idl_fields(path: Path) -> List[Field]:
    """Parse one DDS-form IDL file of mlmap_msgs and return its members.

    Also checks the form rmw expects: one struct `<Name>_` in module `mlmap_msgs::msg::dds_`,
    and an #include of every nested type's own file.
    """
    content = parse_idl_string(strip_include_guard(path.read_text(), str(path)))
    messages = content.get_elements_of_type(definition.Message)
    assert len(messages) == 1, f'{path}: {len(messages)} structs, expected 1'
    structure = messages[0].structure
    namespaced = structure.namespaced_type
    assert [str(n) for n in namespaced.namespaces] == [PACKAGE, 'msg', 'dds_'], path
    assert namespaced.name == path.stem, f'{path}: struct {namespaced.name}'
    includes = {inc.locator for inc in content.get_elements_of_type(definition.Include)}
    for include in includes:
        assert (IDL_ROOT / include).is_file(), f'{path}: #include "{include}" does not exist'
    for member in structure.members:
        nested = member.type
        while isinstance(nested, (definition.AbstractSequence, definition.Array)):
            nested = nested.value_type
        if isinstance(nested, definition.NamespacedType):
            needed = '/'.join([str(n) for n in nested.namespaces[:2]] + [nested.name + '.idl'])
            assert needed in includes, f'{path}: {member.name} needs #include "{needed}"'
    return [(member.name, _idl_type(member.type)) for member in structure.members]


def compare(msg: List[Field], idl: List[Field]) -> List[str]:
    """List every difference between the two field lists, position by position."""
    problems = []
    for i in range(max(len(msg), len(idl))):
        left = msg[i] if i < len(msg) else None
        right = idl[i] if i < len(idl) else None
        if left != right:
            problems.append(f'field {i}: .msg {left} != IDL {right}')
    return problems


def message_names() -> List[str]:
    """Names of the messages that have an IDL file."""
    return sorted(p.stem[:-1] for p in IDL_DIR.glob('*_.idl'))


def test_every_message_has_both_forms_and_is_generated():
    """Each IDL has a .msg twin and the reverse, and CMakeLists.txt generates every .msg."""
    idl_names = message_names()
    msg_names = sorted(p.stem for p in MSG_DIR.glob('*.msg'))
    assert idl_names == msg_names
    assert idl_names, 'no mlmap_msgs IDL found'
    cmake = (MSG_PACKAGE / 'CMakeLists.txt').read_text()
    generated = sorted(re.findall(r'"msg/(\w+)\.msg"', cmake))
    assert generated == msg_names


@pytest.mark.parametrize('name', message_names())
def test_msg_equals_idl(name: str):
    """Same fields, same order, same types in the .msg and the IDL."""
    msg = msg_fields(PACKAGE, name, (MSG_DIR / f'{name}.msg').read_text())
    idl = idl_fields(IDL_DIR / f'{name}_.idl')
    assert compare(msg, idl) == []


@pytest.mark.parametrize('name', message_names())
def test_layout_version_field(name: str):
    """Every mlmap message starts with header and a uint32 layout version (idl/README.md)."""
    msg = msg_fields(PACKAGE, name, (MSG_DIR / f'{name}.msg').read_text())
    assert msg[:2] == [('header_', 'std_msgs::msg::dds_::Header_'), ('version_', 'uint32')]


def _mutations(text: str):
    """Yield (what, changed .msg text) for each kind of change the check must catch."""
    lines = text.splitlines()
    fields = [i for i, line in enumerate(lines) if line.strip() and not line.startswith('#')]
    first, second, last = fields[1], fields[2], fields[-1]
    renamed = list(lines)
    renamed[second] = re.sub(r'^(\S+\s+)(\w+)', r'\1\2x', lines[second])
    yield 'renamed', renamed
    retyped = list(lines)
    retyped[first] = re.sub(r'^\S+', 'uint64' if 'uint32' in lines[first] else 'uint32',
                            lines[first])
    yield 'retyped', retyped
    swapped = list(lines)
    swapped[first], swapped[second] = lines[second], lines[first]
    yield 'swapped', swapped
    yield 'dropped', lines[:last] + lines[last + 1:]
    yield 'added', lines + ['float64 extra']
    array = list(lines)
    array[last] = re.sub(r'^(\S+?)(\[\])?(\s)', lambda m: m.group(1) + (
        '' if m.group(2) else '[]') + m.group(3), lines[last])
    yield 'array changed', array


@pytest.mark.parametrize('name', message_names())
def test_check_catches_every_kind_of_difference(name: str):
    """A renamed, retyped, swapped, dropped or added field, or a changed array, is reported."""
    text = (MSG_DIR / f'{name}.msg').read_text()
    idl = idl_fields(IDL_DIR / f'{name}_.idl')
    for what, lines in _mutations(text):
        changed = msg_fields(PACKAGE, name, '\n'.join(lines) + '\n')
        assert compare(changed, idl), f'a {what} field went unnoticed'


def test_idl_guard_and_preprocessor_rules():
    """The guard stripper refuses anything but one matching include guard."""
    body = '#include "std_msgs/msg/Header_.idl"\nmodule a { };\n'
    good = '#ifndef G\n#define G\n' + body + '#endif\n'
    assert '#ifndef' not in strip_include_guard(good, 'good')
    with pytest.raises(AssertionError):
        strip_include_guard(body, 'no guard')
    with pytest.raises(AssertionError):
        strip_include_guard('#ifndef G\n#define H\n' + body + '#endif\n', 'mismatched guard')
    with pytest.raises(AssertionError):
        strip_include_guard(good.replace(body, '#pragma once\n' + body), 'pragma')
