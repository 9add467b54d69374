"""Write the parameter reference, ``docs/parameters.md``, from the nodes' ``ParamSpec`` tables.

The reference is generated, never edited by hand: each node's ``PARAMETERS`` table is the
one definition of its parameters (names, types, defaults, ranges, whether they can be set
while the node runs, descriptions), the same that ``ros2 param describe`` and ``--help``
show. ``test/nodes/test_parameter_reference.py`` fails while the committed file differs
from what :func:`render` writes; regenerate it with ``make docs`` or::

    python -m scara_ident_ros.nodes.parameter_reference docs/parameters.md
"""
from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from scara_ident_ros.nodes.parameters import ParamSpec

__all__ = ['NODES', 'node_section', 'render', 'main']

#: The nodes with a ``PARAMETERS`` table, in the order of the reference
NODES = ('identifier', 'scara_sim', 'robot_sim', 'excitation', 'recorder', 'player')

HEADER = """\
# Parameters

<!-- Generated from the nodes' ParamSpec tables by
     `python -m scara_ident_ros.nodes.parameter_reference docs/parameters.md` (`make docs`);
     do not edit by hand: a test checks this file against the tables. -->

Every parameter of every node: its type, its default (also in `config/<node>.yaml`), its
unit and range, and whether it can be set while the node runs (`ros2 param set`) or is fixed
at start (and why). `ros2 param describe /<node> <name>` and `ros2 run scara_ident_ros
<node> --help` show the same descriptions. Nodes, topics and services:
[nodes.md](nodes.md).
"""

_ROS_TYPES: dict[type, str] = {bool: 'bool', int: 'integer', float: 'double', str: 'string'}


def type_name(spec: ParamSpec) -> str:
    """The ROS parameter type of ``spec``, as ``ros2 param describe`` names it."""
    if spec.items is not None:
        return f'{_ROS_TYPES.get(spec.items, spec.items.__name__)} array'
    return _ROS_TYPES.get(type(spec.default), type(spec.default).__name__)


def default_text(value: Any) -> str:
    """``value`` as it is written in a YAML parameters file."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return f"'{value}'" if value == '' else value
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(default_text(item) for item in value) + ']'
    return repr(value)


def rules_text(spec: ParamSpec) -> str:
    """The unit, range and choices of ``spec``, e.g. ``s, >= 0.0``."""
    parts = [spec.unit] if spec.unit else []
    if spec.min is not None and spec.max is not None:
        parts.append(f'{spec.min} to {spec.max}')
    elif spec.min is not None:
        parts.append(f'>= {spec.min}')
    elif spec.max is not None:
        parts.append(f'<= {spec.max}')
    if spec.choices:
        parts.append(' \\| '.join(spec.choices))
    return ', '.join(parts)


def cell(text: str) -> str:
    """``text`` safe in a Markdown table cell."""
    return text.replace('|', '\\|').replace('\n', ' ')


def node_section(node: str, specs: Sequence[ParamSpec], summary: str) -> str:
    """The Markdown section of one node: its summary and a table of ``specs``."""
    lines = [f'## {node}', '', summary, '',
             '| name | type | default | unit, range | set | description |',
             '|---|---|---|---|---|---|']
    for spec in specs:
        when = 'while running' if not spec.read_only else 'at start'
        if spec.read_only and spec.fixed:
            when += f': {spec.fixed}'
        code = f'`{default_text(spec.default)}`'
        lines.append(f'| `{spec.name}` | {type_name(spec)} | {cell(code)} '
                     f'| {rules_text(spec)} | {cell(when)} | {cell(spec.description)} |')
    return '\n'.join(lines) + '\n'


def summary_of(module: Any) -> str:
    """The first line of a node module's docstring."""
    doc = (module.__doc__ or '').strip()
    return doc.splitlines()[0] if doc else ''


def render(nodes: Sequence[str] = NODES) -> str:
    """The whole reference: the header, then one section per node (imports rclpy)."""
    sections = [HEADER]
    for node in nodes:
        module = importlib.import_module(f'scara_ident_ros.nodes.{node}')
        sections.append(node_section(node, module.PARAMETERS, summary_of(module)))
    return '\n'.join(sections)


def main(argv: Sequence[str] | None = None) -> int:
    """Write the reference to the path given (``-`` or nothing: standard output)."""
    parser = argparse.ArgumentParser(
        prog='python -m scara_ident_ros.nodes.parameter_reference',
        description='Write the parameter reference (Markdown) from the ParamSpec tables.')
    parser.add_argument('out', nargs='?', default='-',
                        help='file to write, e.g. docs/parameters.md (default: stdout)')
    args = parser.parse_args(argv)
    text = render()
    if args.out == '-':
        sys.stdout.write(text)
    else:
        Path(args.out).write_text(text, encoding='utf-8')
    return 0


if __name__ == '__main__':
    sys.exit(main())
