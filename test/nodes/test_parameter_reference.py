"""``docs/parameters.md`` is what the ``ParamSpec`` tables say, and the docs lead to it.

The reference is generated (``make docs``): a parameter added, removed or changed in a
node's table fails here until the file is written again.
"""
from __future__ import annotations

import importlib
import re
from dataclasses import replace
from pathlib import Path

import pytest

from scara_ident_ros.nodes import parameter_reference
from scara_ident_ros.nodes.parameter_reference import NODES, node_section, render

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / 'docs' / 'parameters.md'


def test_the_committed_reference_is_the_generated_one() -> None:
    assert REFERENCE.read_text(encoding='utf-8') == render(), (
        'docs/parameters.md differs from the ParamSpec tables: run make docs')


@pytest.mark.parametrize('node', NODES)
def test_every_parameter_has_its_row_with_its_default(node: str) -> None:
    text = REFERENCE.read_text(encoding='utf-8')
    section = text.split(f'\n## {node}\n', 1)[1].split('\n## ', 1)[0]
    for spec in importlib.import_module(f'scara_ident_ros.nodes.{node}').PARAMETERS:
        row = next(line for line in section.splitlines()
                   if line.startswith(f'| `{spec.name}` |'))
        assert f'`{parameter_reference.default_text(spec.default)}`' in row.replace('\\|', '|')
        assert ('while running' in row) == (not spec.read_only)


def test_a_changed_description_changes_the_section() -> None:
    specs = importlib.import_module('scara_ident_ros.nodes.player').PARAMETERS
    before = node_section('player', specs, 'the player')
    changed = (replace(specs[0], description='Another text | with a bar'), *specs[1:])
    after = node_section('player', changed, 'the player')
    assert before != after
    assert 'Another text \\| with a bar' in after  # a bar does not split the cell


def test_the_defaults_are_written_as_in_yaml() -> None:
    assert parameter_reference.default_text(True) == 'true'
    assert parameter_reference.default_text('') == "''"
    assert parameter_reference.default_text([]) == '[]'
    assert parameter_reference.default_text(['a', 'b']) == '[a, b]'
    assert parameter_reference.default_text(0.5) == '0.5'


@pytest.mark.parametrize('page', ['README.md', 'docs/nodes.md'])
def test_the_readme_and_the_nodes_page_link_to_the_reference(page: str) -> None:
    links = re.findall(r'\]\(([^)#]+)', (ROOT / page).read_text(encoding='utf-8'))
    targets = {(ROOT / page).parent.joinpath(link).resolve() for link in links}
    assert REFERENCE.resolve() in targets


def test_main_writes_the_reference(tmp_path: Path) -> None:
    out = tmp_path / 'parameters.md'
    assert parameter_reference.main([str(out)]) == 0
    assert out.read_text(encoding='utf-8') == render()
