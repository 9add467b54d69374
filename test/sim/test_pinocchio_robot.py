"""URDF robots on Pinocchio: joints, limits, rotor inertia, friction; the simulator on them.

The reference dynamics are built here independently: the URDF loaded by Pinocchio, the
fingers locked by hand, ``pin.rnea`` plus the friction law written out.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from scara_ident_ros.dynamics.params import ParamError
from scara_ident_ros.dynamics.urdf_limits import UrdfError, read_urdf
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory
from scara_ident_ros.sim.example_robots import (EXAMPLE_ROBOTS, ExampleRobotError,
                                                example_robot)
from scara_ident_ros.sim.pinocchio_robot import (ACCELERATION_PER_VELOCITY,
                                                 ARMATURE_PER_EFFORT, PinocchioRobot)

PANDA_ARM = tuple(f'panda_joint{i}' for i in range(1, 8))
UR5_JOINTS = ('shoulder_pan_joint', 'shoulder_lift_joint', 'elbow_joint', 'wrist_1_joint',
              'wrist_2_joint', 'wrist_3_joint')
EFFORT_TOLERANCE = 1e-9  # N·m: effort = rnea + friction up to rounding (seen: 4e-14)


def robot(name: str) -> PinocchioRobot:
    entry = example_robot(name)
    return PinocchioRobot.from_urdf(entry.urdf, joints=entry.joints)


def friction_law(r: PinocchioRobot, qd: np.ndarray) -> np.ndarray:
    """The friction of the module docstring, written out."""
    f = r.friction
    fv, fc, fs = (np.array(x) for x in (f.viscous, f.coulomb, f.static))
    vs, eps = np.array(f.stribeck_velocity), np.array(f.stick_velocity)
    return (fc + (fs - fc) * np.exp(-(qd / vs) ** 2)) * np.tanh(qd / eps) + fv * qd


def reference_panda() -> tuple[pin.Model, pin.Data]:
    """Panda's arm from its URDF with the fingers locked half open, rotor inertia set."""
    full = pin.buildModelFromUrdf(example_robot('panda').urdf)
    q_lock = pin.neutral(full)
    fingers = [full.getJointId(f'panda_finger_joint{i}') for i in (1, 2)]
    for j in fingers:
        q_lock[full.joints[j].idx_q] = 0.02            # m, middle of [0, 0.04]
    model = pin.buildReducedModel(full, fingers, q_lock)
    model.armature = ARMATURE_PER_EFFORT * np.array([87.0] * 4 + [12.0] * 3)
    return model, model.createData()


def test_every_example_robot_loads_with_the_urdf_names_and_limits() -> None:
    for name in EXAMPLE_ROBOTS:
        r = robot(name)
        limits = read_urdf(example_robot(name).urdf).select(r.joint_names)
        assert r.effort_max == tuple(limits.effort_max)
        assert r.position_min == tuple(limits.position_min)
        assert r.velocity_max == tuple(limits.velocity_max)
    assert robot('ur5').joint_names == UR5_JOINTS
    assert robot('panda').joint_names == PANDA_ARM      # the fingers are locked


def test_panda_matches_an_independent_rnea_plus_friction() -> None:
    r = robot('panda')
    model, data = reference_panda()
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = r.position_centre + rng.uniform(-1.0, 1.0, 7)
        qd, qdd = rng.normal(size=7), rng.normal(size=7) * 5.0
        expected = pin.rnea(model, data, q, qd, qdd) + friction_law(r, qd)
        np.testing.assert_allclose(r.inverse_dynamics(q, qd, qdd), expected, rtol=0,
                                   atol=1e-10)
        # forward dynamics inverts it
        np.testing.assert_allclose(r.forward_dynamics(q, qd, expected), qdd, rtol=0,
                                   atol=1e-9)
    batch_q = r.position_centre + rng.uniform(-1.0, 1.0, (5, 7))
    batch_qd, batch_qdd = rng.normal(size=(5, 7)), rng.normal(size=(5, 7))
    batch = r.inverse_dynamics(batch_q, batch_qd, batch_qdd)
    np.testing.assert_allclose(batch[3], r.inverse_dynamics(batch_q[3], batch_qd[3],
                                                            batch_qdd[3]), atol=1e-12)
    np.testing.assert_allclose(r.forward_dynamics(batch_q, batch_qd, batch), batch_qdd,
                               atol=1e-9)


def test_rotor_inertia_adds_to_the_mass_matrix_diagonal() -> None:
    r = robot('ur5')
    np.testing.assert_allclose(r.armature, ARMATURE_PER_EFFORT * np.array(r.effort_max))
    bare = pin.buildModelFromUrdf(example_robot('ur5').urdf)
    q = r.position_centre + 0.3
    m_bare = pin.crba(bare, bare.createData(), q)
    np.testing.assert_allclose(np.diag(r.mass_matrix(q)) - np.diag(m_bare), r.armature,
                               atol=1e-12)
    custom = PinocchioRobot.from_urdf(example_robot('ur5').urdf, armature=[0.5] * 6)
    assert custom.armature == (0.5,) * 6


def test_default_acceleration_limits_are_bounded_by_effort_and_velocity() -> None:
    rng = np.random.default_rng(7)
    for name in ('ur5', 'panda'):
        r = robot(name)
        limit = np.array(r.acceleration_max)
        by_velocity = ACCELERATION_PER_VELOCITY * np.array(r.velocity_max)
        assert (limit > 0.0).all() and (limit <= by_velocity + 1e-12).all()
        low, high = r.array('position_min'), r.array('position_max')
        poses = low + (high - low) * rng.random((200, r.n_joints))
        heaviest = np.max([np.diag(r.mass_matrix(q)) for q in poses], axis=0)   # kg·m²
        by_effort = 0.5 * np.array(r.effort_max) / heaviest
        # each joint is bound by its velocity limit or, within the sampling of its
        # heaviest pose (64 poses there, 200 here), by half its effort over its inertia
        bound = np.isclose(limit, by_velocity) | np.isclose(limit, by_effort, rtol=0.25)
        assert bound.all(), (name, limit, by_velocity, by_effort)
        assert (limit < by_velocity).any()      # the shoulders are effort-bound
    given = robot('ur5').replaced(acceleration_max=[5.0] * 6)
    assert given.acceleration_max == (5.0,) * 6


def test_joint_selection_and_its_errors(tmp_path: Path) -> None:
    urdf = example_robot('panda').urdf
    with_fingers = PinocchioRobot.from_urdf(urdf)       # a URDF's default: every joint
    assert with_fingers.joint_names == (*PANDA_ARM, 'panda_finger_joint1',
                                        'panda_finger_joint2')
    with pytest.raises(ParamError, match='URDF order'):
        PinocchioRobot.from_urdf(urdf, joints=('panda_joint2', 'panda_joint1'))
    with pytest.raises(ParamError, match='must be distinct joints of the URDF'):
        PinocchioRobot.from_urdf(urdf, joints=('panda_joint1', 'elbow'))
    text = Path(urdf).read_text()
    assert PinocchioRobot.from_urdf(text, joints=PANDA_ARM).source == 'robot_description'
    with pytest.raises(UrdfError, match='not <robot>'):
        PinocchioRobot.from_urdf('<sdf/>')
    with pytest.raises(ParamError, match='cannot read the URDF'):
        PinocchioRobot.from_urdf(tmp_path / 'missing.urdf')
    with pytest.raises(ExampleRobotError, match='known robots are panda'):
        example_robot('pr2')
    continuous = text.replace('name="panda_joint7" type="revolute"',
                              'name="panda_joint7" type="continuous"')
    with pytest.raises(UrdfError, match='panda_joint7 \\(continuous\\)'):
        PinocchioRobot.from_urdf(continuous, joints=PANDA_ARM)


def test_perturbed_changes_the_dynamics_not_the_limits() -> None:
    r = robot('panda')
    other = r.perturbed(0.2, seed=3)
    assert other.effort_max == r.effort_max and other.joint_names == r.joint_names
    q, qd, qdd = r.position_centre, np.full(7, 0.5), np.ones(7)
    change = other.inverse_dynamics(q, qd, qdd) - r.inverse_dynamics(q, qd, qdd)
    assert np.abs(change).max() > 0.1                                  # N·m
    assert r.perturbed(0.0, seed=3).inverse_dynamics(q, qd, qdd) == pytest.approx(
        r.inverse_dynamics(q, qd, qdd))
    with pytest.raises(ParamError, match='relative must be < 1'):
        r.perturbed(1.0, seed=0)


@pytest.mark.parametrize('name', ['ur5', 'panda'])
def test_simulated_arm_stays_within_limits_and_its_effort_is_rnea_plus_friction(
        name: str) -> None:
    r = robot(name)
    n = r.n_joints
    trajectory = make_trajectory('sequence', r, seed=2)
    record = Simulator(r, trajectory, SimConfig(n_joints=n, substeps=1, seed=2)).simulate(6000)
    assert record.q.shape == (6000, n)
    assert (record.q >= r.array('position_min')).all()
    assert (record.q <= r.array('position_max')).all()
    assert (np.abs(record.qd) <= r.array('velocity_max')).all()
    assert (np.abs(record.qdd) <= r.array('acceleration_max')).all()
    assert (np.abs(record.effort) <= r.array('effort_max')).all()
    # tracking: computed torque with the true model follows the excitation closely
    desired = trajectory.evaluate(record.stamp_ns * 1e-9)[0]
    assert np.abs(record.q - desired).max() < 1e-3                     # rad
    # the recorded effort is the inverse dynamics of the recorded state, friction included
    model, data = r.model, r.model.createData()
    rnea = np.array([pin.rnea(model, data, *row) for row in zip(record.q, record.qd,
                                                                  record.qdd)])
    np.testing.assert_allclose(record.effort, rnea + friction_law(r, record.qd), rtol=0,
                               atol=EFFORT_TOLERANCE)


def test_noise_disturbance_and_mismatch_run_on_arrays() -> None:
    r = robot('ur5')
    config = SimConfig(n_joints=6, substeps=1, position_noise=1e-4, effort_noise=0.1,
                       disturbance=0.05, disturbance_kind='random', model_mismatch=0.1, seed=5)
    record = Simulator(r, make_trajectory('standard', r, seed=5), config).simulate(500)
    assert np.isfinite(record.effort).all() and record.effort.shape == (500, 6)
    again = Simulator(r, make_trajectory('standard', r, seed=5), config).simulate(500)
    np.testing.assert_array_equal(record.q, again.q)                  # seeded
    with pytest.raises(ParamError, match=r'for 4 joints, the robot has 6'):
        Simulator(r, make_trajectory('standard', r, seed=5), SimConfig())
