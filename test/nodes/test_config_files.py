"""Each ``config/<node>.yaml`` documents the true defaults of that node's parameters.

For every module ``scara_ident_ros.nodes.<node>`` with a ``PARAMETERS`` tuple of
:class:`ParamSpec` and a ``config/<node>.yaml`` in the ``/**: ros__parameters:``
form, the YAML holds exactly the declared names, each with the default value and
type (a ``1000`` where ``1000.0`` is declared would be rejected by the node).
"""
from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
import yaml

import scara_ident_ros.nodes
from scara_ident_ros.nodes.parameters import ParamSpec

pytestmark = pytest.mark.ros

CONFIG_DIR = Path(__file__).resolve().parents[2] / 'config'


def nodes_with_config() -> list[str]:
    """Node modules with a PARAMETERS table of ParamSpec and a config/<node>.yaml."""
    found = []
    for info in pkgutil.iter_modules(scara_ident_ros.nodes.__path__):
        module = importlib.import_module(f'scara_ident_ros.nodes.{info.name}')
        specs = getattr(module, 'PARAMETERS', None)
        if (isinstance(specs, tuple) and specs
                and all(isinstance(spec, ParamSpec) for spec in specs)
                and (CONFIG_DIR / f'{info.name}.yaml').is_file()):
            found.append(info.name)
    return found


NODES = nodes_with_config()


def typed(value: Any) -> Any:
    """A value with its type spelled out, so that 1 != 1.0 != True compare unequal."""
    if isinstance(value, (list, tuple)):
        return [typed(item) for item in value]
    return (type(value).__name__, value)


def test_every_node_is_found() -> None:
    assert {'identifier', 'scara_sim', 'robot_sim', 'recorder', 'player',
            'excitation'} <= set(NODES)


@pytest.mark.parametrize('node', NODES)
def test_config_file_equals_the_parameter_defaults(node: str) -> None:
    module: ModuleType = importlib.import_module(f'scara_ident_ros.nodes.{node}')
    path = CONFIG_DIR / f'{node}.yaml'
    document = yaml.safe_load(path.read_text())
    assert list(document) == ['/**'], f'{path}: expected one /** section'
    values = document['/**']['ros__parameters']
    defaults = {spec.name: spec.default for spec in module.PARAMETERS}
    assert sorted(values) == sorted(defaults), f'{path}: names differ from {node}.PARAMETERS'
    wrong = {name: (values[name], default) for name, default in defaults.items()
             if typed(values[name]) != typed(default)}
    assert not wrong, f'{path}: (file, default) differ: {wrong}'
