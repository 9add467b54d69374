"""PhysicalModel against Pinocchio's inverse dynamics, friction recovery, RLS, files."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.base_reduction import reduce_columns
from scara_ident_ros.dynamics.physical_options import (CANDIDATES, select_coulomb,
                                                    select_options)
from scara_ident_ros.learners.hybrid_model import HybridModel, fit_hybrid
from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.physical_model import COULOMB_EPS, PhysicalModel
from scara_ident_ros.dynamics.recursive_least_squares import RecursiveLeastSquares
from scara_ident_ros.dynamics.urdf_limits import UrdfError
from scara_ident_ros.identification.rls_trainer import RecursiveLeastSquaresTrainer
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn import FeedForwardNet, ModelFormatError

from physical_robots import SCARA_URDF, example_urdf, rnea, states  # test/

PANDA_ARM = tuple(f'panda_joint{i}' for i in range(1, 8))


@pytest.mark.parametrize('urdf, joints', [(SCARA_URDF, None),
                                          (example_urdf('ur_description/urdf/ur5_robot.urdf'),
                                           None),
                                          (example_urdf('panda_description/urdf/panda.urdf'),
                                           PANDA_ARM)],
                         ids=['scara', 'ur5', 'panda-arm'])
def test_regressor_reproduces_pinocchio_rnea(urdf: Path, joints: tuple[str, ...] | None
                                             ) -> None:
    model = PhysicalModel.from_urdf_file(urdf, joint_names=joints)
    n = model.n_joints
    q, qd, qdd = states(np.random.default_rng(3), 40, n)
    expected = rnea(urdf, joints, q, qd, qdd)
    theta = model.urdf_parameters()  # friction 0
    tau = model.regressor(q, qd, qdd) @ theta
    np.testing.assert_allclose(tau, expected, rtol=1e-10, atol=1e-10)
    model.set_theta(theta)
    np.testing.assert_allclose(model.predict(np.hstack([q, qd, qdd])), expected, rtol=1e-10,
                               atol=1e-10)
    # the standard regressor holds every body's 10 parameters; the base ones are fewer
    assert model.standard_regressor(q, qd, qdd).shape == (40, n, 10 * n + n)
    assert model.n_base < 11 * n and model.n_parameters == model.n_base + 2 * n
    assert model.stacked_regressor(q, qd, qdd).shape == (40 * n, model.n_parameters)


def test_scara_base_parameters_match_the_analytic_model() -> None:
    """The reduced SCARA model equals the project's Lagrangian ScaraModel (no friction)."""
    params = ScaraParams(viscous=(0.0,) * 4, coulomb=(0.0,) * 4)
    model = PhysicalModel.from_urdf_file(SCARA_URDF, armature=False)
    # the analytic model's 6 combinations less w34 (the quill's weight m34·g: g is known
    # here), plus three first moments that the analytic model has at 0
    assert model.n_base == 8
    assert model.base_parameters.keys() == set(model.parameter_names[:8])
    model.set_theta(model.urdf_parameters())
    q, qd, qdd = states(np.random.default_rng(5), 30, 4)
    np.testing.assert_allclose(model.predict(np.hstack([q, qd, qdd])),
                               ScaraModel(params).inverse_dynamics(q, qd, qdd), rtol=1e-9,
                               atol=1e-9)
    # one definition reads as the analytic zz1r's start: link1.Izz plus moments of link 2
    assert any(text.startswith('link1.Izz + ') for text in model.definitions())


def test_reduction_finds_known_dependences() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(50, 1)), rng.normal(size=(50, 1))
    stacked = np.hstack([a, b, 2.0 * a - b, np.zeros((50, 1))])
    reduction = reduce_columns(stacked, ['a', 'b', 'c', 'z'])
    assert reduction.n_base == 2 and set(reduction.dependent.tolist()) >= {3}
    theta = np.array([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(stacked[:, reduction.independent] @ reduction.base_values(theta),
                               stacked @ theta)


@pytest.mark.parametrize('coulomb', ['tanh', 'sign'])
def test_least_squares_recovers_friction_and_base_parameters(coulomb: str) -> None:
    urdf = example_urdf('ur_description/urdf/ur5_robot.urdf')
    model = PhysicalModel.from_urdf_file(urdf, coulomb=coulomb, coulomb_eps=0.02)
    n = model.n_joints
    rng = np.random.default_rng(11)
    truth = model.urdf_parameters()
    viscous, coulomb_level = rng.uniform(0.5, 5.0, n), rng.uniform(1.0, 8.0, n)
    truth[model.n_base:] = np.concatenate([viscous, coulomb_level])
    q, qd, qdd = states(rng, 600, n)
    tau = rnea(urdf, None, q, qd, qdd) + viscous * qd + coulomb_level * model.coulomb_shape(qd)
    model.fit_states(q, qd, qdd, tau)
    np.testing.assert_allclose(model.viscous, viscous, rtol=1e-8)
    np.testing.assert_allclose(model.coulomb_friction, coulomb_level, rtol=1e-8)
    np.testing.assert_allclose(model.theta, truth, rtol=1e-6, atol=1e-8)
    assert model.friction['shoulder_pan_joint'] == pytest.approx((viscous[0], coulomb_level[0]))
    assert np.all(model.residual_rms < 1e-8)


def test_rls_equals_batch_least_squares() -> None:
    model = PhysicalModel.from_urdf_file(SCARA_URDF)
    rng = np.random.default_rng(2)
    q, qd, qdd = states(rng, 400, 4)
    tau = rng.normal(0.0, 10.0, (400, 4))  # any data: both solve the same problem
    batch = model.fit_states(q, qd, qdd, tau).theta.copy()
    rls = RecursiveLeastSquares(model, p0=1e12)
    rls.update(q[:1], qd[:1], qdd[:1], tau[:1])
    for start in range(1, 400, 37):  # blocks of any size
        rls.update(q[start:start + 37], qd[start:start + 37], qdd[start:start + 37],
                   tau[start:start + 37])
    assert rls.count == 400
    np.testing.assert_allclose(rls.theta, batch, rtol=1e-7, atol=1e-9)
    with pytest.raises(ValueError, match='finite'):
        rls.update_rows(np.full((4, model.n_parameters), np.nan), np.zeros(4))


def test_rls_trainer_predicts_a_priori_and_converges() -> None:
    model = PhysicalModel.from_urdf_file(SCARA_URDF)
    truth = model.urdf_parameters()
    truth[model.n_base:] = [3.0, 1.5, 20.0, 0.05, 6.0, 3.0, 15.0, 0.5]
    rng = np.random.default_rng(4)
    q, qd, qdd = states(rng, 300, 4)
    tau = model.regressor(q, qd, qdd) @ truth
    trainer = RecursiveLeastSquaresTrainer(model, p0=1e12)
    first = trainer.learn(np.concatenate([q[0], qd[0], qdd[0]]), tau[0])
    np.testing.assert_array_equal(first, np.zeros(4))  # θ = 0 before the first sample
    for k in range(1, 300):
        x = np.concatenate([q[k], qd[k], qdd[k]])
        before = model.predict(x)
        np.testing.assert_array_equal(trainer.learn(x, tau[k]), before)
    np.testing.assert_allclose(model.theta, truth, rtol=1e-6, atol=1e-8)
    assert trainer.rls.count == 300
    with pytest.raises(ValueError):
        trainer.learn(np.full(12, np.nan), tau[0])
    assert trainer.rls.count == 300
    with pytest.raises(NotImplementedError):
        model.partial_fit(np.zeros((1, 12)), np.zeros((1, 4)))


def test_physical_and_hybrid_files_round_trip(tmp_path: Path) -> None:
    model = PhysicalModel.from_urdf_file(SCARA_URDF, coulomb='sign')
    rng = np.random.default_rng(6)
    q, qd, qdd = states(rng, 200, 4)
    tau = (model.regressor(q, qd, qdd) @ rng.uniform(0.1, 2.0, model.n_parameters)
           + 0.1 * np.sin(3.0 * q))  # something the physical model does not explain
    x = np.hstack([q, qd, qdd])
    model.metadata['method'] = np.array('physical')
    model.fit_states(q, qd, qdd, tau).save(tmp_path / 'physical.npz')
    loaded = PhysicalModel.load(tmp_path / 'physical.npz')
    np.testing.assert_array_equal(loaded.predict(x), model.predict(x))
    assert loaded.parameter_names == model.parameter_names and loaded.coulomb == 'sign'
    assert str(loaded.metadata['method']) == 'physical'
    with pytest.raises(ModelFormatError, match='a physical model, not a network'):
        FeedForwardNet.load(tmp_path / 'physical.npz')

    hybrid, history = fit_hybrid(PhysicalModel.from_urdf_file(SCARA_URDF),
                                 make_network('ffs', 4, n_hidden=8), (x[:150], tau[:150]),
                                 validation=(x[150:], tau[150:]), iterations=20,
                                 min_iterations=0, max_fail=5)
    residual = tau[:150] - hybrid.physical.predict(x[:150])
    # the network's outputs are scaled to the residual's range, not the efforts'
    np.testing.assert_allclose(hybrid.network.y_scaling.hi, residual.max(axis=0))
    assert history.iterations >= 1
    # the network starts at 0: with no iteration the hybrid is the physical model
    still, _ = fit_hybrid(PhysicalModel.from_urdf_file(SCARA_URDF),
                          make_network('ffs', 4, n_hidden=8), (x[:150], tau[:150]),
                          iterations=0)
    np.testing.assert_allclose(still.predict(x), still.physical.predict(x), atol=1e-12)
    hybrid.save(tmp_path / 'hybrid.npz')
    again = HybridModel.load(tmp_path / 'hybrid.npz')
    np.testing.assert_array_equal(again.predict(x), hybrid.predict(x))
    np.testing.assert_array_equal(again.gate, hybrid.gate)  # gated on the validation samples
    assert hybrid.region is not None  # the correction fades away from the training states
    np.testing.assert_allclose(hybrid.predict(x), hybrid.physical.predict(x)
                               + hybrid.network.predict(x) * hybrid.gate
                               * hybrid.region.weight(x)[:, None])
    hybrid.gate = np.ones(4)
    with pytest.raises(ModelFormatError, match='a hybrid model, not a physical one'):
        PhysicalModel.load(tmp_path / 'hybrid.npz')
    # bounded, the network's correction is clipped per joint, and the file keeps the bounds
    correction = hybrid.network.predict(x)
    low, high = np.quantile(correction, 0.25, axis=0), np.quantile(correction, 0.75, axis=0)
    hybrid.bounds = (low, high)
    np.testing.assert_allclose(hybrid.predict(x) - hybrid.physical.predict(x),
                               np.clip(correction, low, high)
                               * hybrid.region.weight(x)[:, None], atol=1e-9)
    hybrid.save(tmp_path / 'bounded.npz')
    bounded = HybridModel.load(tmp_path / 'bounded.npz')
    assert bounded.bounds is not None
    np.testing.assert_array_equal(bounded.bounds[0], low)
    np.testing.assert_array_equal(bounded.predict(x), hybrid.predict(x))


def test_bad_urdfs_and_joints_are_refused() -> None:
    with pytest.raises(UrdfError, match='not distinct joints of the URDF'):
        PhysicalModel.from_urdf_file(SCARA_URDF, joint_names=['joint1', 'elbow'])
    with pytest.raises(UrdfError, match='cannot read'):
        PhysicalModel.from_urdf_file(SCARA_URDF.with_name('nothing.urdf'))
    with pytest.raises(ValueError, match='coulomb'):
        PhysicalModel.from_urdf_file(SCARA_URDF, coulomb='smooth')


@pytest.mark.parametrize('coulomb, eps', [('sign', 1.0), ('tanh', 0.05), ('tanh', 0.2)])
def test_the_coulomb_shape_of_the_data_is_chosen(coulomb: str, eps: float) -> None:
    def build(shape: str, width: float) -> PhysicalModel:
        return PhysicalModel.from_urdf_file(SCARA_URDF, coulomb=shape, coulomb_eps=width)

    truth = build(coulomb, eps)
    theta = truth.urdf_parameters()
    theta[truth.n_base:] = [3.0, 1.5, 20.0, 0.05, 6.0, 3.0, 15.0, 0.5]
    truth.set_theta(theta)
    rng = np.random.default_rng(8)
    q, qd, qdd = states(rng, 600, 4)
    qd *= 0.2  # most speeds within a few ε of 0, where the shapes differ
    x = np.hstack([q, qd, qdd])
    y = truth.predict(x)
    model, choice = select_coulomb(build, (x[:400], y[:400]), (x[400:], y[400:]))
    assert (choice.coulomb, choice.eps) == (coulomb, eps)
    assert choice.label == ('sign' if coulomb == 'sign' else f'tanh {eps:g}')
    assert len(choice.scores) == len(CANDIDATES) and min(choice.scores.values()) < 1e-12
    np.testing.assert_allclose(model.coulomb_friction, [6.0, 3.0, 15.0, 0.5], rtol=1e-6)


def test_a_continuous_joint_takes_its_angle() -> None:
    """Pinocchio holds a continuous joint as (cos, sin); the model takes the angle."""
    text = SCARA_URDF.read_text().replace('<joint name="joint4" type="revolute">',
                                          '<joint name="joint4" type="continuous">')
    model = PhysicalModel(text, source='continuous wrist')
    q, qd, qdd = states(np.random.default_rng(9), 20, 4)
    q[:, 3] *= 3.0  # any angle
    pinocchio_model = pin.buildModelFromXML(text)
    assert pinocchio_model.nq == 5
    data = pinocchio_model.createData()
    q_pin = np.hstack([q[:, :3], np.cos(q[:, 3:]), np.sin(q[:, 3:])])
    expected = np.array([pin.rnea(pinocchio_model, data, q_pin[k], qd[k], qdd[k])
                         for k in range(20)])
    np.testing.assert_allclose(model.regressor(q, qd, qdd) @ model.urdf_parameters(), expected,
                               rtol=1e-10, atol=1e-10)


def test_a_stribeck_column_recovers_the_breakaway_excess(tmp_path: Path) -> None:
    """With ``stribeck_velocity`` the model holds the simulator's friction law exactly:
    f_v q' + (f_c + f_s exp(−(q'/v_s)²)) tanh(q'/ε); the file keeps v_s."""
    urdf = example_urdf('ur_description/urdf/ur5_robot.urdf')
    model = PhysicalModel.from_urdf_file(urdf, coulomb_eps=0.05, stribeck_velocity=0.1)
    n = model.n_joints
    assert model.n_parameters == model.n_base + 3 * n
    assert model.parameter_names[-1] == 'wrist_3_joint.fs'
    rng = np.random.default_rng(5)
    fv, fc, fs = rng.uniform(0.5, 5.0, n), rng.uniform(1.0, 8.0, n), rng.uniform(0.2, 2.0, n)
    q, qd, qdd = states(rng, 600, n)
    qd[::3] *= 0.05  # slow samples, where the Stribeck term is not negligible
    shape = np.tanh(qd / 0.05)
    tau = (rnea(urdf, None, q, qd, qdd) + fv * qd
           + (fc + fs * np.exp(-(qd / 0.1) ** 2)) * shape)
    model.fit_states(q, qd, qdd, tau)
    np.testing.assert_allclose(model.viscous, fv, rtol=1e-7)
    np.testing.assert_allclose(model.coulomb_friction, fc, rtol=1e-7)
    np.testing.assert_allclose(model.stribeck_friction, fs, rtol=1e-6)
    plain = PhysicalModel.from_urdf_file(urdf, coulomb_eps=0.05).fit_states(q, qd, qdd, tau)
    assert np.all(plain.residual_rms > 1e3 * model.residual_rms)
    assert np.all(plain.stribeck_friction == 0.0)
    model.save(tmp_path / 'stribeck.npz')
    loaded = PhysicalModel.load(tmp_path / 'stribeck.npz')
    assert loaded.stribeck_velocity == 0.1
    X = np.hstack([q, qd, qdd])
    np.testing.assert_allclose(loaded.predict(X), model.predict(X), rtol=1e-12)


def test_the_gate_withholds_a_correction_that_makes_held_out_data_worse() -> None:
    """The hybrid's correction is kept per joint only where it lowers the held-out error of
    the physical model alone (``HybridModel.validate_gate``)."""
    physical = PhysicalModel.from_urdf_file(SCARA_URDF, coulomb='sign')
    rng = np.random.default_rng(11)
    q, qd, qdd = states(rng, 600, 4)
    tau = (physical.regressor(q, qd, qdd) @ rng.uniform(0.1, 2.0, physical.n_parameters)
           + 0.5 * np.sin(2.0 * q))  # a residual a network can learn
    x = np.hstack([q, qd, qdd])
    hybrid, _ = fit_hybrid(physical, make_network('ffs', 4, n_hidden=10),
                           (x[:400], tau[:400]), iterations=40, min_iterations=0,
                           max_fail=40)
    held = (x[400:], tau[400:])
    alone, corrected = hybrid.validate_gate(*held)
    assert np.all(corrected < 0.5 * alone)  # the correction helps on every joint
    assert np.all((hybrid.gate > 0.9) & (hybrid.gate <= 1.0))  # kept, barely shrunk
    # spoil joint 2's correction: a bias of 3 N far larger than its residual
    theta = hybrid.network.get_theta()
    _, output = hybrid.network.unpack(theta)
    output[2, -1] += 3.0 / (hybrid.network.y_scaling.hi[2] - hybrid.network.y_scaling.lo[2])
    hybrid.network.set_theta(theta)
    alone, corrected = hybrid.validate_gate(*held)
    assert corrected[2] > alone[2]
    # shrunk to the little of it that still helps (the learnt part under the bias)
    assert hybrid.gate[2] < 0.2 and np.all(hybrid.gate[[0, 1, 3]] > 0.9)
    predicted, base = hybrid.predict(held[0]), hybrid.physical.predict(held[0])
    error = np.mean((predicted - held[1]) ** 2, axis=0)
    assert np.all(error <= np.mean((base - held[1]) ** 2, axis=0))
    # by groups (time blocks): a correction that helps over all samples but hurts much in
    # one of five blocks is withheld; joint 0's residual of the last 40 samples is the
    # correction's opposite
    hybrid.gate = np.ones(4)
    x, y = held[0], held[1].copy()
    y[160:, 0] = (hybrid.physical.predict(x[160:])[:, 0]
                  - hybrid.raw_correction(x[160:])[:, 0])
    alone, corrected = hybrid.validate_gate(x, y, groups=np.zeros(200))
    assert corrected[0] < alone[0] and hybrid.gate[0] > 0.0  # better over all samples
    hybrid.validate_gate(x, y, groups=np.arange(200) // 40)
    assert hybrid.gate[0] == 0.0 and hybrid.gate[2] < 0.2
    assert np.all(hybrid.gate[[1, 3]] > 0.9)


def test_fit_hybrid_gates_on_its_validation_samples(tmp_path: Path) -> None:
    physical = PhysicalModel.from_urdf_file(SCARA_URDF, coulomb='sign')
    rng = np.random.default_rng(12)
    q, qd, qdd = states(rng, 500, 4)
    tau = physical.regressor(q, qd, qdd) @ rng.uniform(0.1, 2.0, physical.n_parameters)
    # joint 0's residual has one sign in training and the other in validation: learnt, it
    # makes validation worse; joint 1's is the same function in both
    tau[:, 0] += np.where(np.arange(500) < 400, 0.3, -0.3)
    tau[:, 1] += 2.0 * np.sin(2.0 * q[:, 1])
    x = np.hstack([q, qd, qdd])
    hybrid, _ = fit_hybrid(physical, make_network('ffs', 4, n_hidden=10),
                           (x[:400], tau[:400]), validation=(x[400:], tau[400:]),
                           iterations=40, min_iterations=40, max_fail=40)
    assert hybrid.gate[0] == 0.0 and hybrid.gate[1] > 0.9
    hybrid.save(tmp_path / 'gated.npz')
    loaded = HybridModel.load(tmp_path / 'gated.npz')
    np.testing.assert_array_equal(loaded.gate, hybrid.gate)
    np.testing.assert_array_equal(loaded.predict(x), hybrid.predict(x))


def test_offsets_asymmetric_and_coupled_friction_are_recovered(tmp_path: Path) -> None:
    """Real arms' columns: an effort offset per joint (none on the SCARA's vertical quill,
    whose weight is already a constant effort), Coulomb friction that differs by direction,
    and friction of a coupled joint's speed."""
    # tanh with a wide ε: with sign(q'), |s(q')| = 1 is the offset's column itself
    model = PhysicalModel.from_urdf_file(SCARA_URDF, coulomb_eps=0.5, offsets=True,
                                         asymmetric=True, coupled=[('joint2', 'joint4')])
    np.testing.assert_array_equal(model.offset_joints, [True, True, False, True])
    assert model.parameter_names[-7:] == (
        'joint2.fv[joint4]', 'joint4.fv[joint2]', 'joint2.fc[joint4]', 'joint4.fc[joint2]',
        'joint1.offset', 'joint2.offset', 'joint4.offset')
    rng = np.random.default_rng(8)
    q, qd, qdd = states(rng, 300, 4)
    truth = model.urdf_parameters()
    truth[model.n_base:] = rng.uniform(0.2, 2.0, model.n_parameters - model.n_base)
    offset = np.array([0.7, -0.4, 0.0, 0.3])
    asymmetric = truth[model.n_base + 8:model.n_base + 12]
    base = PhysicalModel.from_urdf_file(SCARA_URDF, coulomb_eps=0.5)
    shape = model.coulomb_shape(qd)
    tau = (base.regressor(q, qd, qdd) @ truth[:base.n_parameters] + offset
           + asymmetric * np.abs(shape))
    tau[:, 1] += truth[-7] * qd[:, 3] + truth[-5] * shape[:, 3]
    tau[:, 3] += truth[-6] * qd[:, 1] + truth[-4] * shape[:, 1]
    model.fit_states(q, qd, qdd, tau)
    np.testing.assert_allclose(model.effort_offset, offset, atol=1e-7)
    np.testing.assert_allclose(model.asymmetric_friction, asymmetric, rtol=1e-7)
    np.testing.assert_allclose(model.theta[-7:-3], truth[-7:-3], rtol=1e-7)
    np.testing.assert_allclose(model.predict(np.hstack([q, qd, qdd])), tau, atol=1e-8)
    model.save(tmp_path / 'real.npz')
    loaded = PhysicalModel.load(tmp_path / 'real.npz')
    assert loaded.coupled == (('joint2', 'joint4'),) and loaded.parameter_names == \
        model.parameter_names
    np.testing.assert_array_equal(loaded.theta, model.theta)


def test_fit_hybrid_gates_on_other_samples_than_it_stopped_on() -> None:
    """``gate_validation``: the gate is set on those samples, not on the stop's."""
    physical = PhysicalModel.from_urdf_file(SCARA_URDF, coulomb='sign')
    rng = np.random.default_rng(12)
    q, qd, qdd = states(rng, 600, 4)
    tau = physical.regressor(q, qd, qdd) @ rng.uniform(0.1, 2.0, physical.n_parameters)
    tau += 2.0 * np.sin(2.0 * q)  # learnt on every joint ...
    tau[500:, 3] -= 4.0 * np.sin(2.0 * q[500:, 3])  # ... but joint 3's turns in the gate's
    x = np.hstack([q, qd, qdd])
    hybrid, _ = fit_hybrid(physical, make_network('ffs', 4, n_hidden=10),
                           (x[:400], tau[:400]), validation=(x[400:500], tau[400:500]),
                           gate_validation=(x[500:], tau[500:]), iterations=40,
                           min_iterations=40, max_fail=40)
    assert np.all(hybrid.gate[:3] > 0.9) and hybrid.gate[3] == 0.0


def test_options_the_data_need_are_added_and_others_are_not() -> None:
    """Efforts with a coupled-friction term between joints 3 and 4 and none of the offsets:
    the coupling is chosen (it explains the later samples), the offsets are not, the Coulomb
    shape stays the default; imposed options are kept whatever the data say."""
    def build(**options: object) -> PhysicalModel:
        return PhysicalModel.from_urdf_file(SCARA_URDF, **options)  # type: ignore[arg-type]

    truth = build(coupled=(('joint3', 'joint4'),))
    theta = truth.urdf_parameters()
    theta[truth.n_base:truth.n_base + 8] = [3.0, 1.5, 20.0, 0.05, 6.0, 3.0, 15.0, 0.5]
    theta[truth.n_base + 8:] = [8.0, 4.0, 5.0, 2.0]  # joint 3 of q'_4 and 4 of q'_3
    truth.set_theta(theta)
    q, qd, qdd = states(np.random.default_rng(8), 900, 4)
    x = np.hstack([q, qd, qdd])
    y = truth.predict(x)
    model, choice = select_options(build, (x[:600], y[:600]), (x[600:], y[600:]))
    assert choice.options['coupled'] == (('joint3', 'joint4'),)
    assert not choice.options['offsets']
    assert (choice.options['coulomb'], choice.options['coulomb_eps']) == ('tanh', COULOMB_EPS)
    assert choice.label == f'tanh {COULOMB_EPS:g}, coupled joint3,joint4'
    np.testing.assert_allclose(model.predict(x[600:]), y[600:], atol=1e-8)
    _, imposed = select_options(build, (x[:600], y[:600]), (x[600:], y[600:]),
                                fixed={'coupled': (), 'offsets': True})
    assert imposed.options['coupled'] == () and imposed.options['offsets'] is True
