"""A URDF alone makes the identifier predict: the limits it lacks come from the stream's first
second, fixed from then on, said in one line; joints no file knows stay unknown_joint."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from scara_ident_ros.learners.hybrid_model import HybridModel
from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.dynamics.urdf_limits import parse_urdf
from scara_ident_ros.identification import make_differentiator
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.session import IdentificationSession
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.identification.stream_scaling import (ACCELERATION_TIME_S, FLOOR, MARGIN,
                                                           POSITION_HALF_RANGE, StreamScaling)
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim.example_robots import EXAMPLE_ROBOTS, example_robot
from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot

DEFAULTS = IdentifierSettings.from_yaml(config_path('identifier.yaml'))
MS = 1_000_000  # ns
T0 = 1_000 * 1_000_000_000  # ns
RATE = 1000  # Hz


def stream(name: str, seconds: float) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray,
                                                  np.ndarray]:
    """A robot's arm joints moving as slow sines about mid-range: names, q, q', q'' and
    efforts, each (N, n), at :data:`RATE`."""
    robot = PinocchioRobot.from_urdf(example_robot(name).urdf,
                                     joints=EXAMPLE_ROBOTS[name].joints)
    t = np.arange(round(seconds * RATE))[:, None] / RATE
    low, high = robot.array('position_min'), robot.array('position_max')
    n = len(low)
    amplitude, omega = 0.1 * (high - low), 2 * np.pi * np.linspace(0.15, 0.3, n)
    q = 0.5 * (low + high) + amplitude * np.sin(omega * t)
    qd = amplitude * omega * np.cos(omega * t)
    qdd = -amplitude * omega ** 2 * np.sin(omega * t)
    return list(robot.joint_names), q, qd, qdd, robot.inverse_dynamics(q, qd, qdd)


def session_for(name: str, lines: list[str], **changes: Any) -> IdentificationSession:
    return IdentificationSession(
        DEFAULTS.replace(**{'lm_background': False, 'trainer': 'bp',
                            'urdf_file': str(example_robot(name).urdf), **changes}),
        log=lines.append)


def feed(session: IdentificationSession, names: list[str], q: np.ndarray, qd: np.ndarray,
         effort: np.ndarray, start: int = 0) -> tuple[int, list[str]]:
    """Process samples start..; return the predictions made and the warnings."""
    predicted, warnings = 0, []
    for i in range(start, len(q)):
        outcome = session.process(T0 + i * MS, names, q[i], qd[i], effort[i])
        predicted += len(outcome.predictions[0])
        warnings += outcome.warnings
    return predicted, warnings


@pytest.mark.parametrize('robot', ['panda', 'ur5'])
def test_a_urdf_alone_predicts_every_sample_after_the_warm_up(robot: str) -> None:
    names, q, qd, qdd, effort = stream(robot, 2.0)
    lines: list[str] = []
    session = session_for(robot, lines)
    predicted, warnings = feed(session, names, q, qd, effort)
    assert warnings == [] and session.core is not None
    summary = session.summary()
    assert summary.skipped.as_dict() == {}  # no unknown_joint, nothing else
    lag = DEFAULTS.window // 2
    assert predicted == len(q) - lag == summary.predicted  # the last lag are pending
    # one line says which limits, from where: the URDF's, and the stream's accelerations
    said = [line for line in lines if line.startswith('joint limits of')]
    assert len(said) == 1 and str(names) in said[0]
    assert f"the stream's first 1.00 s ({RATE + 1} samples)" in said[0]
    network = session.network
    assert isinstance(network, FeedForwardNet)
    limits = parse_urdf(Path(example_robot(robot).urdf).read_text()).select(names)
    n = len(names)
    x_min, x_max = network.x_scaling.lo, network.x_scaling.hi
    y_min, y_max = network.y_scaling.lo, network.y_scaling.hi
    np.testing.assert_array_equal(x_min[:n], limits.position_min)
    np.testing.assert_array_equal(x_max[n:2 * n], limits.velocity_max)
    np.testing.assert_array_equal(y_max, limits.effort_max)
    np.testing.assert_array_equal(y_min, -limits.effort_max)
    # acceleration: MARGIN x the first second's largest |q''| (the estimate's, close to the
    # true one), at least velocity_max / ACCELERATION_TIME_S
    first_second = np.abs(qdd[:RATE + 1]).max(axis=0)
    expected = np.maximum(MARGIN * first_second, limits.velocity_max / ACCELERATION_TIME_S)
    np.testing.assert_allclose(x_max[2 * n:], expected, rtol=0.02)
    assert np.all(x_max[2 * n:] > 0)


def test_the_scaling_is_fixed_once_set_and_larger_inputs_are_still_predicted() -> None:
    names, q, qd, qdd, effort = stream('panda', 1.5)
    session = session_for('panda', [])
    feed(session, names, q, qd, effort)
    network = session.network
    assert isinstance(network, FeedForwardNet)
    before = network.x_scaling.hi.copy()
    n = len(names)
    # a 20 Hz tremor of 30 % of the velocity limits: q'' beyond the scaling (unbounded by
    # the checks), velocities within the URDF's bounds; still predicted
    n = len(names)
    t = np.arange(len(q))[:, None] / RATE
    limits = parse_urdf(Path(example_robot('panda').urdf).read_text()).select(names)
    tremor = 0.3 * limits.velocity_max * np.sin(2 * np.pi * 20.0 * t)
    fast_qd = qd + tremor
    start = len(q)
    stamps = T0 + (start + np.arange(len(q))) * MS
    predicted, largest = 0, 0.0
    for i, stamp in enumerate(stamps):
        outcome = session.process(int(stamp), names, q[i], fast_qd[i], effort[i])
        assert outcome.warnings == ()
        for item in outcome.inputs:
            largest = max(largest, np.abs(network.x_scaling.transform(item.x)).max())
        for result in outcome.predictions[0]:
            predicted += 1
            assert result.effort is not None and np.all(np.isfinite(result.effort))
    assert predicted == len(q)
    np.testing.assert_array_equal(network.x_scaling.hi, before)  # never re-estimated
    assert largest > 3.0  # the scaled inputs went far beyond [-1, 1]
    session.reset()
    assert isinstance(session.network, FeedForwardNet)
    np.testing.assert_array_equal(session.network.x_scaling.hi[2 * n:], before[2 * n:])


def test_joints_no_file_knows_stay_unknown() -> None:
    names, q, qd, _, effort = stream('panda', 0.1)
    lines: list[str] = []
    session = session_for('panda', lines)
    wrong = [*names[:-1], 'elbow_of_another_arm']
    _, warnings = feed(session, wrong, q, qd, effort)
    assert session.core is None
    assert session.summary().skipped.as_dict() == {'unknown_joint': len(q)}
    assert "no joint limits for ['elbow_of_another_arm']" in warnings[0]


def test_joint_names_of_the_urdf_need_no_acceleration_limits() -> None:
    names, q, qd, _, effort = stream('ur5', 1.2)
    session = session_for('ur5', [], joint_names=names[::-1])
    assert session.core is None  # built once the stream has completed the scaling
    feed(session, names, q, qd, effort)
    assert session.names == names[::-1] and session.summary().skipped.total == 0


def test_a_physical_model_needs_no_scaling_and_holds_the_fingers_fixed() -> None:
    names, q, qd, _, effort = stream('panda', 0.2)  # the arm's 7 joints, not the fingers
    lines: list[str] = []
    session = session_for('panda', lines, method='physical')
    predicted, warnings = feed(session, names, q, qd, effort)
    assert warnings == [] and predicted == len(q) - DEFAULTS.window // 2
    model = session.network
    assert isinstance(model, PhysicalModel) and model.joint_names == tuple(names)
    assert any('joint limits of' in line for line in lines)
    # the fingers, not in the stream, are held at Pinocchio's neutral position (0 m): the
    # URDF's rigid-body efforts with them there, before anything is learnt
    still = session_for('panda', [], method='physical', learn=False)
    full = pin.buildModelFromUrdf(str(example_robot('panda').urdf))
    fingers = [full.getJointId(f'panda_finger_joint{i}') for i in (1, 2)]
    arm = pin.buildReducedModel(full, fingers, pin.neutral(full))
    data, n, checked = arm.createData(), len(names), 0
    for i in range(60):
        outcome = still.process(T0 + i * MS, names, q[i], qd[i], effort[i])
        for result, item in zip(outcome.predictions[0], outcome.inputs):
            x = item.x
            assert result.effort is not None
            expected = pin.rnea(arm, data, x[:n], x[n:2 * n], x[2 * n:])
            np.testing.assert_allclose(result.effort, expected, rtol=1e-6, atol=1e-9)
            checked += 1
    assert checked == 60 - DEFAULTS.window // 2


CONTINUOUS = """<robot name="wheel">
  <link name="base"/><link name="arm"/><link name="wheel"/>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="arm"/>
    <limit lower="0" upper="0.5" velocity="0.2" effort="100"/></joint>
  <joint name="spin" type="continuous"><parent link="arm"/><child link="wheel"/></joint>
</robot>"""


def test_a_continuous_joint_takes_every_limit_from_the_stream_and_is_not_bounded() -> None:
    files = JointLimits.of([], {key: [] for key in ('position_min', 'position_max',
                                                      'velocity_max', 'acceleration_max',
                                                      'effort_max')})
    scaling = StreamScaling(files, parse_urdf(CONTINUOUS), ['spin', 'lift'],
                            make_differentiator('centred', window=5))
    t = np.arange(1101) / RATE
    for i, ti in enumerate(t):  # spin turns at 3 rad/s from 1 rad with 2 N·m; lift at rest
        assert scaling.add(T0 + i * MS, ['lift', 'spin'], [0.1, 1.0 + 3.0 * ti],
                           [0.0, 3.0], [50.0, 2.0]) is None
    assert scaling.ready
    limits = scaling.limits()
    np.testing.assert_allclose(limits.velocity_max, [MARGIN * 3.0, 0.2])
    np.testing.assert_allclose(limits.effort_max, [MARGIN * 2.0, 100.0])
    np.testing.assert_allclose(limits.acceleration_max,  # nothing accelerates: the floors
                               [MARGIN * 3.0 / ACCELERATION_TIME_S, 0.2 / ACCELERATION_TIME_S])
    centre, half = 1.0 + 3.0 * t[-1] / 2, max(MARGIN * 3.0 * t[-1] / 2, POSITION_HALF_RANGE)
    np.testing.assert_allclose([limits.position_min[0], limits.position_max[0]],
                               [centre - half, centre + half])
    np.testing.assert_allclose([limits.position_min[1], limits.position_max[1]], [0.0, 0.5])
    bounds = scaling.bounds(0.5)
    assert bounds is not None
    assert np.all(np.isinf(bounds.hi[:, 0])) and np.all(np.isfinite(bounds.hi[:, 1]))
    assert "['spin']: all from the stream (no URDF limits" in limits.source
    assert "the stream's first 1.10 s (1101 samples)" in limits.source
    assert FLOOR == 1.0


def test_a_sample_of_other_joints_while_scaling_is_skipped() -> None:
    names, q, qd, _, effort = stream('panda', 0.05)
    session = session_for('panda', [])
    feed(session, names, q[:10], qd[:10], effort[:10])
    warnings = session.process(T0 + 20 * MS, names[:3], q[20, :3], qd[20, :3],
                               effort[20, :3]).warnings
    assert warnings and session.summary().skipped.as_dict() == {
        SkipReason.MISSING_JOINT.value: 1}


def test_several_methods_share_the_scaling_the_stream_gave() -> None:
    names, q, qd, _, effort = stream('panda', 1.2)
    lines: list[str] = []
    session = session_for('panda', lines, methods=['ffs', 'hybrid', 'physical'])
    feed(session, names, q, qd, effort)
    for run in session.runs:
        summary = session.summary(run)
        assert summary.skipped.total == 0, run.method
        assert summary.predicted == len(q) - DEFAULTS.window // 2, run.method
    ffs, hybrid = session.runs[0].network, session.runs[1].network
    assert isinstance(ffs, FeedForwardNet)
    assert isinstance(hybrid, HybridModel)
    np.testing.assert_array_equal(hybrid.network.x_scaling.hi,
                                  ffs.x_scaling.hi)
