"""The ``excitation`` node in its own process, against a fake arm (a test node publishing
``/joint_states`` and listening as the controller on its topic) and against ``scara_sim``
as the controller (``trajectory:=external``).

Every chunk it sends is checked on every point: within the limits with margins, continuous
in q, q', q'', at rest at its end, and equal to the chunk before it where both follow the
plan. A stop (SIGINT, ``~/stop``, lost ``/joint_states``) must arrive before its own stop
begins and decelerate along the path within the acceleration limits to rest.
"""
from __future__ import annotations

import json
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from rostest import Listener, NodeProcess  # test/nodes/rostest.py

sys.path.insert(0, str(Path(__file__).parents[1] / 'excitation'))
from smoothness import assert_consistent  # noqa: E402

from scara_ident_ros.dynamics.joint_limits import JointLimits  # noqa: E402
from scara_ident_ros.excitation import ExcitationPlan, load_motion_limits  # noqa: E402

pytestmark = pytest.mark.ros

MODULE = 'scara_ident_ros.nodes.excitation'
SIM = 'scara_ident_ros.nodes.scara_sim'
TOPIC = '/joint_trajectory_controller/joint_trajectory'
ROOT = Path(__file__).resolve().parents[2]
URDF = str(ROOT / 'urdf' / 'scara.urdf')
NAMES = ['joint1', 'joint2', 'joint3', 'joint4']
CENTRE = [0.0, 0.0, 0.1, 0.0]
TIMEOUT = 60.0  # s: generous, the machine is shared
S = 1_000_000_000  # ns
LIMITS: JointLimits = load_motion_limits(urdf_file=URDF)
MARGINED = LIMITS.with_margins(0.1, 0.5, 0.5)


@dataclass
class Received:
    """A chunk as received: plan times (s) from its origin, q, q', q'' (m, 4)."""

    origin_ns: int
    received_ns: int
    times: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


class FakeArm:
    """Publishes a still arm's ``/joint_states`` at 100 Hz and takes the commands."""

    def __init__(self, listener: Listener, position: list[float],
                 names: list[str] = NAMES) -> None:
        self.listener = listener
        self.chunks: list[Received] = []
        self.publishing = True
        publisher = listener.node.create_publisher(JointState, '/joint_states', 10)

        def publish() -> None:
            if self.publishing:
                publisher.publish(JointState(name=names, position=position))
        listener.node.create_timer(0.01, publish)
        listener.node.create_subscription(JointTrajectory, TOPIC, self.take, 10)

    def take(self, msg: JointTrajectory) -> None:
        assert list(msg.joint_names) == NAMES
        points = msg.points
        self.chunks.append(Received(
            msg.header.stamp.sec * S + msg.header.stamp.nanosec, time.time_ns(),
            np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9
                      for p in points]),
            *(np.array([getattr(p, name) for p in points], dtype=float)
              for name in ('positions', 'velocities', 'accelerations'))))

    def spin_until(self, done: object, timeout: float = TIMEOUT) -> None:
        assert self.listener.spin_until(done, timeout), f'{len(self.chunks)} chunks'  # type: ignore[arg-type]


def excitation(*extra: str, state_timeout: float = 3.0) -> NodeProcess:
    """The node on the SCARA's URDF; a state timeout longer than the default, so that a
    busy machine's pause in /joint_states does not stop the tests that do not test it."""
    return NodeProcess(MODULE, ['-p', f'urdf_file:={URDF}', '-p', 'wait_timeout:=30.0',
                                '-p', f'state_timeout:={state_timeout}', *extra])


def check_chunks(chunks: list[Received], start: np.ndarray) -> None:
    """Every chunk within the margins and smooth, at rest at its end; neighbours equal on
    the plan; each received before the one before it begins its stop."""
    assert len({chunk.origin_ns for chunk in chunks}) == 1
    for chunk in chunks:
        assert MARGINED.violations(chunk.q, chunk.qd, chunk.qdd, position_hull=start) == []
        assert_consistent(chunk.times, chunk.q, chunk.qd, chunk.qdd, rtol=0.02)
        assert np.all(chunk.qd[-1] == 0.0) and np.all(np.abs(chunk.qdd[-1]) < 1e-9)
    plan = ExcitationPlan(MARGINED, start, seed=0)
    for old, new in zip(chunks, chunks[1:]):
        received = (new.received_ns - new.origin_ns) / S
        on_plan_old = old.times <= received + 0.05
        np.testing.assert_allclose(old.q[on_plan_old], plan.evaluate(
            old.times[on_plan_old])[0], rtol=0, atol=1e-9)
        # the switch happens where both still follow the plan: no jump (before the plan's
        # origin, its first point: the start at rest, where the arm is)
        assert new.times[0] <= max(received, 0.0)


def assert_smooth_stop(chunks: list[Received], start: np.ndarray) -> None:
    """The last chunk cut the motion short and came before its stop began."""
    check_chunks(chunks, start)
    last, before = chunks[-1], chunks[-2]
    plan = ExcitationPlan(MARGINED, start, seed=0)
    planned = plan.evaluate(last.times)
    stopping = np.flatnonzero(np.any(np.abs(last.q - planned[0]) > 1e-9, axis=1))
    assert stopping.size, 'the last chunk never leaves the plan'
    stop_time = last.times[stopping[0] - 1]
    assert (last.received_ns - last.origin_ns) / S < stop_time
    assert stop_time < before.times[-1] - 0.5  # earlier than the last chunk's own stop
    tail = last.times >= stop_time
    assert np.all(np.abs(last.qdd[tail]) <= MARGINED.acceleration_max * (1 + 1e-6))
    assert np.abs(last.qd[stopping[0] - 1]).max() > 0.0  # it was moving


def test_sigint_mid_trajectory_stops_the_arm_smoothly(listener: Listener,
                                                      tmp_path: Path) -> None:
    arm = FakeArm(listener, CENTRE)
    with excitation('-p', f'stats_file:={tmp_path / "stats.json"}') as node:
        arm.spin_until(lambda: len(arm.chunks) >= 10)  # 2.25 s: in the approach's motion
        node.process.send_signal(signal.SIGINT)
        arm.spin_until(node.exited)
        output = node.wait(TIMEOUT)
    listener.spin_until(lambda: False, 0.3)
    assert output.returncode == 0, output.stderr
    assert_smooth_stop(arm.chunks, np.array(CENTRE))
    stats = json.loads((tmp_path / 'stats.json').read_text())
    assert stats['stop_reason'] == 'interrupted' and stats['chunks_sent'] == len(arm.chunks)


def test_the_stop_service_stops_the_arm_smoothly(listener: Listener) -> None:
    start = [0.5, -0.4, 0.08, 1.0]
    arm = FakeArm(listener, start)
    with excitation('-p', 'chunk_period:=0.2') as node:
        arm.spin_until(lambda: len(arm.chunks) >= 12)
        response = listener.call(Trigger, '/excitation/stop', Trigger.Request())
        assert response.success, response.message
        arm.spin_until(node.exited)
        output = node.wait(TIMEOUT)
    listener.spin_until(lambda: False, 0.3)
    assert output.returncode == 0, output.stderr
    assert '~/stop called: stopping' in output.stderr
    assert_smooth_stop(arm.chunks, np.array(start))


def test_the_optimized_plan_is_sent_within_the_limits_and_stopped(listener: Listener,
                                                                  tmp_path: Path) -> None:
    """``plan:=optimized``: the node optimises first, then sends the approach and the
    periodic motion in chunks that keep to the limits; SIGINT brings it to rest."""
    start = [0.5, -0.4, 0.08, 1.0]
    arm = FakeArm(listener, start)
    with excitation('-p', 'plan:=optimized', '-p', 'harmonics:=3', '-p', 'base_period:=4.0',
                    '-p', f'stats_file:={tmp_path / "stats.json"}') as node:
        arm.spin_until(lambda: len(arm.chunks) >= 12)
        node.process.send_signal(signal.SIGINT)
        arm.spin_until(node.exited)
        output = node.wait(TIMEOUT)
    listener.spin_until(lambda: False, 0.3)
    assert output.returncode == 0, output.stderr
    assert 'optimised in ' in output.stderr and 'then the optimized excitation' in output.stderr
    for chunk in arm.chunks:
        assert MARGINED.violations(chunk.q, chunk.qd, chunk.qdd,
                                   position_hull=np.array(start)) == []
        assert_consistent(chunk.times, chunk.q, chunk.qd, chunk.qdd, rtol=0.02)
        assert np.all(chunk.qd[-1] == 0.0) and np.all(np.abs(chunk.qdd[-1]) < 1e-9)
    np.testing.assert_allclose(arm.chunks[0].q[0], start, atol=1e-12)
    # not the random sequence's plan
    random = ExcitationPlan(MARGINED, np.array(start), seed=0)
    last = arm.chunks[-2]
    assert np.abs(last.q - random.evaluate(last.times)[0]).max() > 1e-3
    assert json.loads((tmp_path / 'stats.json').read_text())['plan'] == 'optimized'


def test_lost_joint_states_stop_the_arm_and_end_with_an_error(listener: Listener) -> None:
    arm = FakeArm(listener, CENTRE)
    with excitation(state_timeout=0.5) as node:
        arm.spin_until(lambda: len(arm.chunks) >= 8)
        arm.publishing = False
        arm.spin_until(node.exited)
        output = node.wait(TIMEOUT)
    listener.spin_until(lambda: False, 0.3)
    assert output.returncode == 1, output.stderr
    errors = [line for line in output.stderr.splitlines() if 'error:' in line]
    assert len(errors) == 1 and 'no /joint_states for' in errors[0]
    assert_smooth_stop(arm.chunks, np.array(CENTRE))


@pytest.mark.parametrize('names, position, extra, message', [
    (['joint1', 'joint2', 'joint3', 'other'], CENTRE, [], "joints ['joint4'] are not in"),
    (NAMES, [0.0, 2.6, 0.1, 0.0], [], 'starts outside its limits: joint2 = 2.6'),
    (NAMES, CENTRE, ['-p', 'use_action:=true'], 'use_action needs control_msgs'),
    (None, CENTRE, ['-p', 'wait_timeout:=1.0'], 'no /joint_states after 1 s'),
])
def test_refusals_are_one_line_and_exit_2_and_move_nothing(
        names: list[str] | None, position: list[float], extra: list[str], message: str,
        listener: Listener) -> None:
    arm = FakeArm(listener, position, names or NAMES)
    arm.publishing = names is not None
    with NodeProcess(MODULE, ['-p', f'urdf_file:={URDF}', *extra]) as node:
        arm.spin_until(node.exited)
        output = node.wait(TIMEOUT)
    assert output.returncode == 2, output.stderr
    errors = [line for line in output.stderr.splitlines() if 'error' in line.lower()]
    assert len(errors) == 1 and message in errors[0], output.stderr
    assert arm.chunks == []


def test_a_urdf_without_limits_is_refused(tmp_path: Path) -> None:
    urdf = tmp_path / 'arm.urdf'
    urdf.write_text('<robot name="arm"><link name="a"/><link name="b"/>'
                    '<joint name="spin" type="continuous"><parent link="a"/>'
                    '<child link="b"/><axis xyz="0 0 1"/></joint></robot>')
    with NodeProcess(MODULE, ['-p', f'urdf_file:={urdf}', '-p', 'joint_names:=[spin]',
                              '-p', 'acceleration_max:=[1.0]']) as node:
        output = node.wait(TIMEOUT)
    assert output.returncode == 2
    assert output.stderr.strip().count('\n') == 0
    assert 'excitation: error:' in output.stderr and 'spin (continuous)' in output.stderr


@pytest.mark.slow
def test_the_loop_excitation_scara_sim_joint_states(listener: Listener,
                                                    tmp_path: Path) -> None:
    """excitation -> scara_sim (trajectory:=external, as the controller) -> /joint_states:
    the arm follows the plan to within 0.02 rad / 0.02 m (loose: the stamps of the two
    processes' clocks), then comes to rest; excitation ends by itself (duration)."""
    states: list[JointState] = listener.subscribe(JointState, '/joint_states')
    stats = tmp_path / 'stats.json'
    with NodeProcess(SIM, ['-p', 'trajectory:=external']) as sim:
        assert listener.spin_until(lambda: len(states) > 100, TIMEOUT)
        with excitation('-p', 'duration:=3.0', '-p', f'stats_file:={stats}') as node:
            assert listener.spin_until(node.exited, TIMEOUT)
            output = node.wait(TIMEOUT)
        listener.spin_until(lambda: False, 0.5)
        sim.stop()
    assert output.returncode == 0, output.stderr
    run = json.loads(stats.read_text())
    assert run['stop_reason'] == 'duration reached'
    stamps = np.array([m.header.stamp.sec * S + m.header.stamp.nanosec for m in states])
    q = np.array([m.position for m in states])
    qd = np.array([m.velocity for m in states])
    t = (stamps - run['origin_ns']) / S
    plan = ExcitationPlan(MARGINED, np.array(run['start']), seed=0)
    moving = (t >= 0) & (t <= run['stop_time'])
    assert moving.sum() > 3000
    error = np.abs(q[moving] - plan.evaluate(t[moving])[0]).max(axis=0)
    assert np.all(error < 0.02), error
    assert np.ptp(q[moving], axis=0).min() > 0.02
    rest = t > run['rest_time'] + 0.3
    assert rest.sum() > 10 and np.abs(qd[rest]).max() < 1e-3


def test_the_optimized_plan_moves_scara_sim_and_brings_it_to_rest(listener: Listener,
                                                                  tmp_path: Path) -> None:
    """excitation plan:=optimized -> scara_sim (trajectory:=external) -> /joint_states: the
    simulated arm moves every joint within the limits, then rests; duration ends it."""
    states: list[JointState] = listener.subscribe(JointState, '/joint_states')
    stats = tmp_path / 'stats.json'
    with NodeProcess(SIM, ['-p', 'trajectory:=external']) as sim:
        assert listener.spin_until(lambda: len(states) > 100, TIMEOUT)
        with excitation('-p', 'duration:=3.0', '-p', 'plan:=optimized', '-p', 'harmonics:=3',
                        '-p', 'base_period:=4.0', '-p', f'stats_file:={stats}') as node:
            assert listener.spin_until(node.exited, 3 * TIMEOUT)
            output = node.wait(TIMEOUT)
        listener.spin_until(lambda: False, 0.5)
        sim.stop()
    assert output.returncode == 0, output.stderr
    run = json.loads(stats.read_text())
    assert run['stop_reason'] == 'duration reached' and run['plan'] == 'optimized'
    stamps = np.array([m.header.stamp.sec * S + m.header.stamp.nanosec for m in states])
    q = np.array([m.position for m in states])
    qd = np.array([m.velocity for m in states])
    t = (stamps - run['origin_ns']) / S
    moving = (t >= 0) & (t <= run['stop_time'])
    assert moving.sum() > 3000
    assert np.ptp(q[moving], axis=0).min() > 0.01
    assert LIMITS.violations(q[moving], qd[moving], np.zeros_like(q[moving])) == []
    rest = t > run['rest_time'] + 0.3
    assert rest.sum() > 10 and np.abs(qd[rest]).max() < 1e-3


def test_robot_sim_follows_a_command_as_a_controller(listener: Listener) -> None:
    """robot_sim (a UR5 on Pinocchio) with trajectory:=external holds mid-range, then
    follows a JointTrajectory on the controller's topic to its last point, at rest."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectoryPoint

    from scara_ident_ros.sim.example_robots import example_robot
    from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot

    entry = example_robot('ur5')
    robot = PinocchioRobot.from_urdf(entry.urdf, joints=entry.joints)
    names, centre = list(robot.joint_names), robot.position_centre
    states: list[JointState] = listener.subscribe(JointState, '/joint_states')
    publisher = listener.node.create_publisher(JointTrajectory, TOPIC, 10)
    goal = centre + 0.2
    with NodeProcess('scara_ident_ros.nodes.robot_sim',
                     ['-p', 'robot:=ur5', '-p', 'trajectory:=external']) as sim:
        assert listener.spin_until(lambda: len(states) > 200, TIMEOUT), sim.stderr_so_far()
        np.testing.assert_allclose(states[-1].position, centre, atol=1e-6)
        assert listener.spin_until(lambda: publisher.get_subscription_count() > 0, TIMEOUT)
        command = JointTrajectory(joint_names=names[::-1])  # matched by name
        command.points = [JointTrajectoryPoint(
            positions=goal[::-1].tolist(), velocities=[0.0] * len(names),
            accelerations=[0.0] * len(names), time_from_start=Duration(sec=1))]
        publisher.publish(command)
        sent = len(states)
        assert listener.spin_until(lambda: len(states) > sent + 2500, TIMEOUT)
        sim.stop()
    assert 'refused' not in sim.stderr_so_far()
    np.testing.assert_allclose(states[-1].position, goal, atol=1e-3)
    assert np.abs(states[-1].velocity).max() < 1e-3
