"""The ``robot_sim`` node in its own process: a UR5 and a Panda streamed at 1 kHz.

What is streamed must be the URDF's joints, every 1 ms, within the URDF's limits (and the
acceleration limits the node derives), and each effort must be Pinocchio's inverse
dynamics (``pin.rnea``, rotor inertia included) plus the friction law on the streamed
state, to :data:`EFFORT_TOLERANCE`. JointState carries no acceleration: the accelerations
are those of the same simulation run in-process, whose states must equal the streamed ones
(the simulation is deterministic).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from sensor_msgs.msg import JointState

from rostest import Listener, NodeProcess  # test/nodes/rostest.py

from scara_ident_ros.nodes.robot_sim import SUBSTEPS, robot_from_settings
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory
from scara_ident_ros.sim.example_robots import example_robot
from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot

pytestmark = pytest.mark.ros

MODULE = 'scara_ident_ros.nodes.robot_sim'
JOINT_STATES_TOPIC = '/joint_states'
MS = 1_000_000  # ns
N = 1500  # samples streamed per robot
EFFORT_TOLERANCE = 1e-9  # N·m: rounding only (seen in-process: 4e-14)
STATE_TOLERANCE = 1e-12  # rad, rad/s: the streamed state is the in-process one
RECEIVE_TIMEOUT = 60.0  # s: generous, the machine is shared
EXIT_TIMEOUT = 30.0  # s
ROBOTS = {
    'ur5': ('shoulder_pan_joint', 'shoulder_lift_joint', 'elbow_joint', 'wrist_1_joint',
            'wrist_2_joint', 'wrist_3_joint'),
    'panda': tuple(f'panda_joint{i}' for i in range(1, 8)),   # the fingers are locked
}


def field(messages: list[JointState], name: str) -> np.ndarray:
    """One float64[] field of every message, shape (n, joints)."""
    return np.array([getattr(m, name) for m in messages], dtype=np.float64)


def settings(**given: object) -> dict[str, object]:
    """robot_sim's robot parameters at their defaults, with ``given`` ones."""
    names = ('robot', 'urdf_file', 'robot_description')
    lists = ('joints', 'acceleration_max', 'armature', 'viscous', 'coulomb',
             'static_friction', 'stribeck_velocity', 'stick_velocity')
    return {**dict.fromkeys(names, ''), **{name: [] for name in lists}, **given}


@pytest.mark.parametrize('name', list(ROBOTS))
def test_streams_the_urdf_joints_at_1khz_and_effort_is_rnea_plus_friction(
        name: str, listener: Listener) -> None:
    messages = listener.subscribe(JointState, JOINT_STATES_TOPIC)
    seed = 6
    with NodeProcess(MODULE, ['-p', f'robot:={name}', '-p', 'wait_for_subscribers:=1',
                              '-p', f'seed:={seed}', '-p', 'stamp_origin:=zero']) as node:
        assert listener.spin_until(lambda: len(messages) >= N, RECEIVE_TIMEOUT), (
            f'received {len(messages)} of {N} joint states in {RECEIVE_TIMEOUT} s')
        output = node.stop()
    assert output.returncode == 0, output.stderr
    messages = messages[:N]
    assert all(tuple(m.name) == ROBOTS[name] for m in messages)
    stamps = np.array([m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
                       for m in messages], dtype=np.int64)
    np.testing.assert_array_equal(stamps, np.arange(N) * MS)     # 1 kHz, no gap
    q, qd, effort = (field(messages, f) for f in ('position', 'velocity', 'effort'))

    entry = example_robot(name)
    robot = PinocchioRobot.from_urdf(entry.urdf, joints=entry.joints)
    assert (q >= robot.array('position_min')).all() and (q <= robot.array('position_max')).all()
    assert (np.abs(qd) <= robot.array('velocity_max')).all()
    assert (np.abs(effort) <= robot.array('effort_max')).all()

    record = Simulator(robot, make_trajectory('sequence', robot, seed=seed),
                       SimConfig(n_joints=robot.n_joints, substeps=SUBSTEPS, seed=seed)
                       ).simulate(N)
    np.testing.assert_allclose(q, record.q, rtol=0, atol=STATE_TOLERANCE)
    np.testing.assert_allclose(qd, record.qd, rtol=0, atol=STATE_TOLERANCE)
    assert (np.abs(record.qdd) <= robot.array('acceleration_max')).all()
    data = robot.model.createData()
    rnea = np.array([pin.rnea(robot.model, data, *row) for row in zip(q, qd, record.qdd)])
    np.testing.assert_allclose(effort, rnea + robot.friction(qd), rtol=0,
                               atol=EFFORT_TOLERANCE)


def test_parameters_override_friction_limits_and_joints() -> None:
    urdf = example_robot('panda').urdf
    robot, what = robot_from_settings(settings(
        robot_description=Path(urdf).read_text(), joints=list(ROBOTS['panda']),
        coulomb=[1.0] * 7, static_friction=[2.0] * 7, acceleration_max=[3.0] * 7))
    assert what == 'robot_description' and robot.joint_names == ROBOTS['panda']
    assert robot.friction.coulomb == (1.0,) * 7 and robot.friction.static == (2.0,) * 7
    assert robot.friction.viscous == tuple(0.02 * e for e in robot.effort_max)  # default
    assert robot.acceleration_max == (3.0,) * 7
    robot, _ = robot_from_settings(settings(urdf_file=urdf))
    assert len(robot.joint_names) == 9                       # a URDF's default: all joints


@pytest.mark.parametrize(('given', 'named'), [
    ({}, 'give exactly one of the parameters robot'),
    ({'robot': 'ur5', 'urdf_file': '/x.urdf'}, "got ['robot', 'urdf_file']"),
    ({'robot': 'pr2'}, "unknown robot 'pr2'"),
    ({'urdf_file': '/nonexistent/r.urdf'}, '/nonexistent/r.urdf'),
    ({'robot': 'ur5', 'joints': ['elbow_joint', 'wrist_9']}, 'must be distinct joints'),
    ({'robot': 'ur5', 'viscous': [1.0]}, "'viscous' must have 6 values"),
    ({'robot': 'ur5', 'armature': [1.0]}, 'armature must have 6 values'),
    ({'robot': 'ur5', 'coulomb': [9.0] * 6, 'static_friction': [1.0] * 6}, 'must be >= coulomb'),
])
def test_bad_robot_parameters_say_what_is_wrong(given: dict, named: str) -> None:
    with pytest.raises(ConfigError, match=named.replace('[', r'\[').replace(']', r'\]')):
        robot_from_settings(settings(**given))


@pytest.mark.parametrize(('ros_args', 'named'), [
    ([], 'give exactly one of the parameters robot'),
    (['-p', 'robot:=ur5', '-p', 'substeps:=1', '-p', 'rate_hz:=100.0'],
     'too long for the friction'),
    (['-p', 'robot:=ur5', '-p', 'viscous:=[1.0]'], "'viscous' must have 6 values"),
])
def test_bad_input_ends_with_one_line(ros_args: list[str], named: str) -> None:
    with NodeProcess(MODULE, ros_args) as node:
        output = node.wait(EXIT_TIMEOUT)
    lines = output.stderr.strip().splitlines()
    assert output.returncode == 2
    assert len(lines) == 1, output.stderr
    assert lines[0].startswith('robot_sim: error:') and named in lines[0], lines[0]
