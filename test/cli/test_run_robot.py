"""``scara-ident run --robot NAME``: robot_sim for scara_sim, the URDF to the identifiers."""
from __future__ import annotations

import pytest

from scara_ident_ros.cli import CliError
from scara_ident_ros.cli.run import _simulator
from scara_ident_ros.sim.example_robots import example_robot
from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot


def test_without_robot_the_scara_simulator_and_no_extra_arguments() -> None:
    assert _simulator(None) == ('scara_sim', [], [])


def test_a_robot_starts_robot_sim_and_gives_identifiers_its_urdf_and_limits() -> None:
    name, sim_args, identifier_args = _simulator('panda')
    assert name == 'robot_sim' and sim_args == ['-p', 'robot:=panda']
    given = dict(identifier_args[i + 1].split(':=', 1) for i in range(0, len(identifier_args), 2))
    entry = example_robot('panda')
    assert given['urdf_file'] == entry.urdf
    assert given['joint_names'] == '[' + ','.join(f'panda_joint{i}' for i in range(1, 8)) + ']'
    limits = [float(x) for x in given['acceleration_max'].strip('[]').split(',')]
    assert all('.' in x or 'e' in x for x in given['acceleration_max'].strip('[]').split(','))
    robot = PinocchioRobot.from_urdf(entry.urdf, joints=entry.joints)
    assert tuple(limits) == robot.acceleration_max      # the limits robot_sim derives


def test_an_unknown_robot_is_a_cli_error() -> None:
    with pytest.raises(CliError, match="--robot: unknown robot 'pr2'; known robots are"):
        _simulator('pr2')
