"""Each node's ``config/<node>.yaml`` says it holds the built-in defaults: it must, key for
key, so that a user who edits a copy starts from what the node does without it."""
from __future__ import annotations

import importlib

import pytest
import yaml

from scara_ident_ros.resources import config_path

NODES = ('identifier', 'scara_sim', 'robot_sim', 'recorder', 'player', 'excitation')


@pytest.mark.parametrize('node', NODES)
def test_the_config_file_holds_every_default(node: str) -> None:
    specs = importlib.import_module(f'scara_ident_ros.nodes.{node}').PARAMETERS
    with open(config_path(f'{node}.yaml'), encoding='utf-8') as stream:
        values = yaml.safe_load(stream)['/**']['ros__parameters']
    assert sorted(values) == sorted(spec.name for spec in specs)
    assert {spec.name: values[spec.name] for spec in specs
            if values[spec.name] != spec.default} == {}
