"""``launch/identification.launch.py``, checked without ``launch`` installed.

There is no ``launch`` or ``launch_ros`` here (no full ROS 2 install): the file is run
against stand-ins for their classes, which only keep the arguments they were given,
and the tests look at the description it builds: the nodes ``scara-ident run`` starts,
a handler that ends the launch when the recorder exits, and handlers that make the
launch fail (``ros2 launch`` exits 1) when a node exits with an error.
"""
from __future__ import annotations

import importlib.util
import sys
import types
from pathlib import Path
from typing import Any

import pytest

from scara_ident_ros.nodes.runtime import STOP_TIMEOUT

pytestmark = pytest.mark.ros

LAUNCH_FILE = Path(__file__).resolve().parents[2] / 'launch' / 'identification.launch.py'
STAND_INS = {
    'launch': ['LaunchDescription'],
    'launch.actions': ['DeclareLaunchArgument', 'LogInfo', 'RegisterEventHandler', 'Shutdown'],
    'launch.conditions': ['IfCondition'],
    'launch.event_handlers': ['OnProcessExit'],
    'launch.substitutions': ['LaunchConfiguration', 'PathJoinSubstitution'],
    'launch_ros.actions': ['Node'],
    'launch_ros.substitutions': ['FindPackageShare'],
}


class StandIn:
    """Any launch class: keeps its positional and keyword arguments."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args = args
        self.kwargs = kwargs


def _stand_in_modules() -> dict[str, types.ModuleType]:
    modules = {}
    for name, classes in STAND_INS.items():
        module = types.ModuleType(name)
        for cls in classes:
            setattr(module, cls, type(cls, (StandIn,), {}))
        modules[name] = module
    modules['launch_ros'] = types.ModuleType('launch_ros')
    return modules


@pytest.fixture
def description(monkeypatch: pytest.MonkeyPatch) -> list[StandIn]:
    """The actions of the launch description the file generates."""
    for name, module in _stand_in_modules().items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location('identification_launch', LAUNCH_FILE)
    assert spec is not None and spec.loader is not None
    launch_file = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(launch_file)
    generated = launch_file.generate_launch_description()
    assert type(generated).__name__ == 'LaunchDescription'
    return list(generated.args[0])


def of_type(actions: list[StandIn], name: str) -> list[StandIn]:
    return [action for action in actions if type(action).__name__ == name]


def test_the_file_imports_without_launch_installed() -> None:
    spec = importlib.util.spec_from_file_location('identification_launch', LAUNCH_FILE)
    assert spec is not None and spec.loader is not None
    spec.loader.exec_module(importlib.util.module_from_spec(spec))  # no ImportError


def test_it_starts_the_graph_of_scara_ident_run(description: list[StandIn]) -> None:
    nodes = of_type(description, 'Node')
    executables = sorted(node.kwargs['executable'] for node in nodes)
    assert executables == ['identifier', 'recorder', 'scara_sim']
    identifier = next(node for node in nodes if node.kwargs['executable'] == 'identifier')
    assert identifier.kwargs['parameters'][1]['methods'] == ['ffmw', 'ffw', 'ffs']
    arguments = {action.args[0] for action in of_type(description, 'DeclareLaunchArgument')}
    assert arguments == {'bag', 'sim'}


def test_its_nodes_run_and_wait_as_scara_ident_runs_do(description: list[StandIn]) -> None:
    """The priorities of scara-ident run, and each node waits for the graph's own
    subscribers by name (another subscriber on the domain does not count as them)."""
    from scara_ident_ros.nodes.realtime import GRAPH_PRIORITIES

    given = {node.kwargs['executable']: node.kwargs['parameters'][1]
             for node in of_type(description, 'Node')}
    for executable, role in (('scara_sim', 'simulator'), ('identifier', 'identifier'),
                             ('recorder', 'recorder')):
        assert given[executable]['realtime_priority'] == GRAPH_PRIORITIES[role], executable
    names = {node.kwargs['executable']: node.kwargs['name'] for node in of_type(description,
                                                                                'Node')}
    assert given['scara_sim']['wait_for_nodes'] == [f"/{names['recorder']}",
                                                    f"/{names['identifier']}"]
    assert given['identifier']['wait_for_nodes'] == [f"/{names['recorder']}"]


class Exited:
    """launch's ProcessExited event, as far as the handlers read it."""

    def __init__(self, returncode: int) -> None:
        self.returncode = returncode


def on_exit_of(description: list[StandIn]) -> dict[str, Any]:
    """The OnProcessExit callback registered for each node, by executable."""
    handlers = [register.args[0] for register in of_type(description, 'RegisterEventHandler')]
    on_exit = [handler for handler in handlers if type(handler).__name__ == 'OnProcessExit']
    return {handler.kwargs['target_action'].kwargs['executable']: handler.kwargs['on_exit']
            for handler in on_exit}


def test_the_launch_ends_when_the_recorder_exits(description: list[StandIn]) -> None:
    recorder = next(node for node in of_type(description, 'Node')
                    if node.kwargs['executable'] == 'recorder')
    callbacks = on_exit_of(description)
    actions = callbacks['recorder'](Exited(0), None)
    assert [type(action).__name__ for action in actions] == ['LogInfo', 'Shutdown']
    assert 'recorder' in actions[1].kwargs['reason']
    handlers = [register.args[0] for register in of_type(description, 'RegisterEventHandler')]
    assert any(h.kwargs['target_action'] is recorder for h in handlers)


@pytest.mark.parametrize('returncode', [1, 2, -9])
def test_a_node_that_fails_ends_the_launch_with_an_error(
        description: list[StandIn], returncode: int) -> None:
    """ros2 launch returns LaunchService.run's code: 1 once an event handler has raised (a
    Shutdown action alone ends it with 0). A node refusing its parameters exits 2."""
    callbacks = on_exit_of(description)
    assert sorted(callbacks) == ['identifier', 'recorder', 'scara_sim']  # every node
    for callback in callbacks.values():
        with pytest.raises(RuntimeError, match=rf'exited with code {returncode}:'):
            callback(Exited(returncode), None)
    assert callbacks['identifier'](Exited(0), None) is None  # a clean exit: the rest go on
    assert callbacks['scara_sim'](Exited(0), None) is None


def test_the_handlers_are_registered_before_the_nodes_start(
        description: list[StandIn]) -> None:
    names = [type(action).__name__ for action in description]
    assert max(i for i, n in enumerate(names) if n == 'RegisterEventHandler') < \
        min(i for i, n in enumerate(names) if n == 'Node')


def test_every_node_gets_the_grace_its_stop_needs(description: list[StandIn]) -> None:
    """Ctrl-C on the launch: launch escalates to SIGTERM and SIGKILL only after a node's own
    stop could have ended (STOP_TIMEOUT), so saves and statistics are written."""
    for node in of_type(description, 'Node'):
        for key in ('sigterm_timeout', 'sigkill_timeout'):
            assert float(node.kwargs[key]) > STOP_TIMEOUT, (node.kwargs['executable'], key)
