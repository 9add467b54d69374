"""The follower of external trajectory commands samples them as joint_trajectory_controller
does, and the simulated SCARA tracks the excitation's chunks through it."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.excitation import ExcitationPlan, load_motion_limits, make_chunk
from scara_ident_ros.sim import SimConfig, Simulator
from scara_ident_ros.sim.example_robots import example_robot
from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot, default_acceleration_max
from scara_ident_ros.sim.trajectory_follower import TrajectoryFollower

ROOT = Path(__file__).resolve().parents[2]
NAMES = ('a', 'b')
S = 1_000_000_000  # ns


def quintic(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A polynomial of degree 5 per joint: its samples must be interpolated exactly."""
    c = np.array([[0.1, -0.3, 0.5, 0.2, -0.4, 0.05], [1.0, 0.2, 0.0, -0.3, 0.1, 0.02]])
    powers = np.vander(t, 6, increasing=True)
    q = powers @ c.T
    qd = powers[:, :5] @ (c[:, 1:] * np.arange(1, 6)).T
    qdd = powers[:, :4] @ (c[:, 2:] * np.arange(2, 6) * np.arange(1, 5)).T
    return q, qd, qdd


def test_it_holds_then_interpolates_then_holds_the_last_point_at_rest() -> None:
    follower = TrajectoryFollower(NAMES, np.array([0.5, -0.5]))
    q, qd, qdd = follower.evaluate(np.array([0.0, 3.0]))
    np.testing.assert_array_equal(q, [[0.5, -0.5]] * 2)
    assert not qd.any() and not qdd.any()
    points = np.array([1.0, 1.4, 2.0])
    pq, pqd, pqdd = quintic(points)
    # received at t = 0.5 s, starting at 0: already running, no segment from the hold
    assert follower.command(NAMES, 0, [round(x * S) for x in points], pq, pqd, pqdd,
                            now_ns=S // 2) is None
    t = np.linspace(1.0, 2.0, 101)[:-1]  # at the last point the follower holds it at rest
    for ours, exact in zip(follower.evaluate(t), quintic(t)):
        np.testing.assert_allclose(ours, exact, rtol=0, atol=1e-12)
    q, qd, qdd = follower.evaluate(np.array([2.5, 9.0]))
    np.testing.assert_allclose(q, [pq[-1]] * 2, rtol=0, atol=1e-15)
    assert not qd.any() and not qdd.any()


def test_a_command_from_the_future_starts_from_the_state_it_replaces() -> None:
    follower = TrajectoryFollower(NAMES, np.zeros(2))
    # columns in another order than the follower's joints: mapped by name
    assert follower.command(('b', 'a'), None, [S], [[2.0, 1.0]], [[0.0, 0.0]], [[0.0, 0.0]],
                            now_ns=S) is None
    q, qd, _ = follower.evaluate(np.array([1.0, 1.5, 2.0]))
    np.testing.assert_allclose(q[0], [0.0, 0.0])
    np.testing.assert_allclose(q[1], [0.5, 1.0])  # the quintic from rest, half way
    np.testing.assert_allclose(q[2], [1.0, 2.0])
    assert qd[1, 0] > 0


@pytest.mark.parametrize('names, times, positions, reason', [
    (('a',), [S], [[1.0]], 'joints'),
    (NAMES, [], [], 'no points'),
    (NAMES, [S, S], [[1.0, 1.0]] * 2, 'increase'),
    (NAMES, [S], [[np.nan, 1.0]], 'not finite'),
    (NAMES, [S], [[1.0, 1.0, 1.0]], 'positions'),
])
def test_bad_commands_are_refused_and_the_current_one_goes_on(
        names: tuple[str, ...], times: list[int], positions: list[list[float]],
        reason: str) -> None:
    follower = TrajectoryFollower(NAMES, np.array([0.1, 0.2]))
    assert reason in (follower.command(names, None, times, positions, None, None, 0) or '')
    assert (follower.received, follower.refused) == (0, 1)
    np.testing.assert_array_equal(follower.evaluate(5.0)[0], [0.1, 0.2])


def test_a_command_that_ended_before_it_came_is_refused() -> None:
    follower = TrajectoryFollower(NAMES, np.zeros(2))
    assert 'ends before' in follower.command(NAMES, S, [S], [[1.0, 1.0]], None, None,
                                             now_ns=3 * S)


def scara() -> tuple[ScaraParams, str, tuple[float, ...]]:
    return (ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml'),
            str(ROOT / 'urdf' / 'scara.urdf'), ())


def ur5() -> tuple[PinocchioRobot, str, tuple[float, ...]]:
    entry = example_robot('ur5')
    robot = PinocchioRobot.from_urdf(entry.urdf, joints=entry.joints)
    return robot, entry.urdf, default_acceleration_max(robot)


@pytest.mark.parametrize('arm', [scara, ur5])
def test_the_simulated_arm_tracks_the_excitation_chunks(arm: object) -> None:
    """``trajectory:=external`` in-process, the SCARA and a UR5 (URDF, Pinocchio): chunks
    sent every 0.25 s as the node sends them; the arm holds until the plan's origin, then
    tracks the plan to within 5 mrad / 5 mm (the SCARA's own sequence: about 2.5 mrad), and
    comes to rest after the last."""
    params, urdf, acceleration_max = arm()  # type: ignore[operator]
    limits = load_motion_limits(urdf_file=urdf, joint_names=params.joint_names,
                                acceleration_max=acceleration_max)
    margined = limits.with_margins(0.1, 0.5, 0.5)
    follower = TrajectoryFollower(params.joint_names, params.position_centre)
    simulator = Simulator(params, follower, SimConfig(n_joints=len(params.joint_names)))
    plan = ExcitationPlan(margined, params.position_centre, seed=4)
    origin = 0.5                       # s of simulated time: plan time 0
    end = origin + plan.approach_duration + 6.0
    q, stamps = [], []
    for k in range(round((end + 1.0) * 1000)):
        now = k * 1e-3
        if k % 250 == 0 and now < end - 1.0:
            chunk = make_chunk(plan, now - origin - 0.01, max(0.0, now - origin + 1.0), 0.01,
                               margined)
            assert follower.command(params.joint_names, round(origin * S),
                                    [round(x * S) for x in chunk.times], chunk.q, chunk.qd,
                                    chunk.qdd, simulator.stamp_ns) is None
        sample = simulator.step()
        q.append(sample.q)
        stamps.append(sample.stamp_ns / S)
    q, t = np.array(q), np.array(stamps)
    held = t < origin
    np.testing.assert_allclose(q[held], np.tile(params.position_centre, (held.sum(), 1)),
                               rtol=0, atol=1e-9)
    moving = (t >= origin) & (t <= chunk.stop_time + origin)
    planned = plan.evaluate(t[moving] - origin)[0]
    error = np.abs(q[moving] - planned).max(axis=0)
    assert np.all(error < 5e-3), error
    assert np.ptp(q[moving], axis=0).min() > 0.05  # it moved
    at_rest = t > chunk.rest_time + origin + 0.2
    assert np.ptp(q[at_rest], axis=0).max() < 1e-4
