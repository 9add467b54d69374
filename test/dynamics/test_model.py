"""Tests of ScaraModel: structure of M and C, energy balance, kinematics, Pinocchio agreement."""
from __future__ import annotations

import math

import numpy as np
import pytest

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ScaraParams

N_STATES = 50


def random_params(rng: np.random.Generator) -> ScaraParams:
    """A random but physically valid parameter set."""
    l1, l2 = rng.uniform(0.2, 0.8), rng.uniform(0.1, 0.5)
    return ScaraParams(
        l1=l1, l2=l2, lc1=rng.uniform(0.0, 1.0) * l1, lc2=rng.uniform(0.0, 1.0) * l2,
        m1=rng.uniform(0.5, 20.0), m2=rng.uniform(0.5, 15.0), m3=rng.uniform(0.2, 5.0),
        m4=rng.uniform(0.2, 8.0), izz1=rng.uniform(0.01, 0.5), izz2=rng.uniform(0.005, 0.2),
        izz3=rng.uniform(1e-4, 0.01), izz4=rng.uniform(1e-3, 0.05), d4=rng.uniform(0.0, 0.2),
        gravity=rng.uniform(9.0, 10.5), viscous=tuple(rng.uniform(0.0, 5.0, 4)),
        coulomb=tuple(rng.uniform(0.0, 5.0, 4)), coulomb_eps=rng.uniform(0.01, 0.2))


def random_states(rng: np.random.Generator, n: int = N_STATES
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = rng.uniform(-math.pi, math.pi, (n, 4))
    q[:, 2] = rng.uniform(-0.1, 0.3, n)
    return q, rng.normal(0.0, 3.0, (n, 4)), rng.normal(0.0, 10.0, (n, 4))


@pytest.fixture(scope='module')
def model() -> ScaraModel:
    return ScaraModel(ScaraParams())


# -- structure ----------------------------------------------------------------------------------

def test_mass_matrix_symmetric_positive_definite(model: ScaraModel) -> None:
    rng = np.random.default_rng(1)
    q, _, _ = random_states(rng, 200)
    q[:4, 1] = [0.0, math.pi, -math.pi, 1e-9]        # stretched and folded arm
    mass = model.mass_matrix(q)
    assert mass.shape == (200, 4, 4)
    np.testing.assert_array_equal(mass, np.swapaxes(mass, 1, 2))
    assert np.linalg.eigvalsh(mass).min() > 0.0


def test_mdot_minus_2c_is_skew_symmetric() -> None:
    rng = np.random.default_rng(2)
    for _ in range(5):
        model = ScaraModel(random_params(rng))
        q, qd, _ = random_states(rng, 20)
        h = 1e-6
        mdot = (model.mass_matrix(q + h * qd) - model.mass_matrix(q - h * qd)) / (2.0 * h)
        skew = mdot - 2.0 * model.coriolis_matrix(q, qd)
        scale = np.abs(mdot).max()
        np.testing.assert_allclose(skew + np.swapaxes(skew, 1, 2), 0.0, atol=1e-8 * scale)


def test_coriolis_vector_is_matrix_times_velocity(model: ScaraModel) -> None:
    rng = np.random.default_rng(3)
    q, qd, _ = random_states(rng)
    np.testing.assert_allclose(model.coriolis(q, qd),
                               np.einsum('nij,nj->ni', model.coriolis_matrix(q, qd), qd),
                               rtol=1e-14, atol=1e-12)


def test_gravity_loads_joint3_downward(model: ScaraModel) -> None:
    p = model.params
    g = model.gravity(np.array([0.3, -1.0, 0.1, 2.0]))
    np.testing.assert_array_equal(g, [0.0, 0.0, -(p.m3 + p.m4) * p.gravity, 0.0])
    # holding still takes an upward (negative) force on the quill
    tau = model.inverse_dynamics(np.zeros(4), np.zeros(4), np.zeros(4))
    assert tau[2] < 0 and np.all(tau[[0, 1, 3]] == 0.0)
    # left alone the quill falls: d3 grows
    assert model.forward_dynamics(np.zeros(4), np.zeros(4), np.zeros(4))[2] > 0


def test_friction_is_viscous_plus_smooth_coulomb(model: ScaraModel) -> None:
    p = model.params
    qd = np.array([0.5, -0.01, 1e-3, -4.0])
    expected = (np.array(p.viscous) * qd
                + np.array(p.coulomb) * np.tanh(qd / p.coulomb_eps))
    np.testing.assert_allclose(model.friction(qd), expected, rtol=1e-15)
    assert np.all(model.friction(-qd) == -model.friction(qd))


def test_forward_inverse_round_trip() -> None:
    rng = np.random.default_rng(4)
    model = ScaraModel(random_params(rng))
    q, qd, qdd = random_states(rng)
    tau = model.inverse_dynamics(q, qd, qdd)
    np.testing.assert_allclose(model.forward_dynamics(q, qd, tau), qdd, rtol=1e-10,
                               atol=1e-10)
    disturbance = rng.normal(0.0, 2.0, (N_STATES, 4))
    np.testing.assert_allclose(model.forward_dynamics(q, qd, tau + disturbance, disturbance),
                               qdd, rtol=1e-10, atol=1e-10)


def test_single_state_fast_path_matches_batch() -> None:
    rng = np.random.default_rng(5)
    model = ScaraModel(random_params(rng))
    q, qd, qdd = random_states(rng, 20)
    tau = model.inverse_dynamics(q, qd, qdd)
    for i in range(20):
        np.testing.assert_allclose(model.inverse_dynamics_single(q[i], qd[i], qdd[i]),
                                   tau[i], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(model.forward_dynamics_single(q[i], qd[i], tau[i]),
                                   qdd[i], rtol=1e-10, atol=1e-10)


def test_single_and_batch_shapes(model: ScaraModel) -> None:
    q = np.array([0.1, 0.2, 0.05, 0.3])
    qb = np.tile(q, (3, 1))
    assert model.mass_matrix(q).shape == (4, 4)
    assert model.coriolis_matrix(qb, qb).shape == (3, 4, 4)
    assert model.forward_kinematics(q).shape == (4, 4)
    assert model.forward_kinematics(qb).shape == (3, 4, 4)
    assert model.inverse_dynamics(q, q, q).shape == (4,)
    assert model.inverse_dynamics(qb, q, q).shape == (3, 4)      # broadcasts
    assert model.forward_dynamics(qb, qb, qb).shape == (3, 4)
    assert isinstance(model.kinetic_energy(q, q), float)
    assert model.kinetic_energy(qb, qb).shape == (3,)
    assert isinstance(model.potential_energy(q), float)
    np.testing.assert_allclose(model.inverse_dynamics(qb, qb, qb)[1],
                               model.inverse_dynamics(q, q, q))
    with pytest.raises(ValueError, match=r'shape \(4,\) or \(N, 4\)'):
        model.mass_matrix(np.zeros(3))
    with pytest.raises(ValueError, match=r'shape \(4,\) or \(N, 4\)'):
        model.gravity(np.zeros((2, 2, 4)))


# -- energy -------------------------------------------------------------------------------------

def test_energy_balance_along_a_simulated_motion() -> None:
    """dE/dt = q'·(τ − F(q')): integrate the power with the state by RK4 and compare."""
    rng = np.random.default_rng(6)
    params = random_params(rng)
    model = ScaraModel(params)
    amp = rng.uniform(0.5, 3.0, 4)
    freq = rng.uniform(0.5, 2.0, 4)                 # Hz

    def torque(t: float) -> np.ndarray:
        return amp * np.sin(2.0 * math.pi * freq * t) + model.gravity(np.zeros(4))

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        q, qd = x[:4], x[4:8]
        tau = torque(t)
        qdd = np.array(model.forward_dynamics_single(q, qd, tau))
        power = float(qd @ (tau - model.friction(qd)))
        return np.concatenate([qd, qdd, [power]])

    x = np.concatenate([[0.2, -0.5, 0.05, 1.0], rng.normal(0.0, 1.0, 4), [0.0]])
    energy0 = model.kinetic_energy(x[:4], x[4:8]) + model.potential_energy(x[:4])
    h, t = 2e-4, 0.0
    for _ in range(5000):                            # 1 s
        k1 = rhs(t, x)
        k2 = rhs(t + h / 2, x + h / 2 * k1)
        k3 = rhs(t + h / 2, x + h / 2 * k2)
        k4 = rhs(t + h, x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t += h
    energy = model.kinetic_energy(x[:4], x[4:8]) + model.potential_energy(x[:4])
    work = x[8]
    assert abs(work) > 0.1                           # the test exercises something
    assert abs(energy - energy0 - work) < 1e-9 * max(1.0, abs(energy0), abs(work))


def test_potential_energy_gradient_is_gravity(model: ScaraModel) -> None:
    rng = np.random.default_rng(7)
    q, _, _ = random_states(rng, 5)
    h = 1e-6
    for j in range(4):
        step = np.zeros(4)
        step[j] = h
        grad = (model.potential_energy(q + step) - model.potential_energy(q - step)) / (2 * h)
        np.testing.assert_allclose(grad, model.gravity(q)[:, j], atol=1e-7)


# -- kinematics ---------------------------------------------------------------------------------

def dh(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Eq. 4: A = Rot(z, θ) Trans(z, d) Trans(x, a) Rot(x, α)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def test_forward_kinematics_is_product_of_dh_matrices() -> None:
    rng = np.random.default_rng(8)
    params = random_params(rng)
    model = ScaraModel(params)
    q, _, _ = random_states(rng, 20)
    poses = model.forward_kinematics(q)
    for (t1, t2, d3, t4), pose in zip(q, poses):
        # Table 1 with alpha_2 = pi, as in the printed A2 (z axes of frames 2-4 point down)
        expected = (dh(t1, 0.0, params.l1, 0.0) @ dh(t2, 0.0, params.l2, math.pi)
                    @ dh(0.0, d3, 0.0, 0.0) @ dh(t4, params.d4, 0.0, 0.0))
        np.testing.assert_allclose(pose, expected, atol=1e-14)
        # closed form of scara-model.md
        x = params.l1 * math.cos(t1) + params.l2 * math.cos(t1 + t2)
        y = params.l1 * math.sin(t1) + params.l2 * math.sin(t1 + t2)
        np.testing.assert_allclose(pose[:3, 3], [x, y, -d3 - params.d4], atol=1e-14)
        yaw = math.atan2(pose[1, 0], pose[0, 0])
        assert math.isclose(math.remainder(yaw - (t1 + t2 - t4), 2 * math.pi), 0.0,
                            abs_tol=1e-12)
        np.testing.assert_allclose(pose[:3, 2], [0.0, 0.0, -1.0], atol=1e-15)


# -- Pinocchio: the acceptance test of the physics ----------------------------------------------

import pinocchio as pin  # noqa: E402  (pinned in constraints.txt: its absence is a failure)


def inertia_with_izz(rng: np.random.Generator, izz: float) -> np.ndarray:
    """A rotational inertia whose zz element is ``izz``; the others must not matter."""
    ixx, iyy = izz + rng.uniform(0.0, 0.1), izz + rng.uniform(0.0, 0.1)
    off = rng.uniform(-0.1, 0.1, 3) * min(ixx, iyy, izz) * 0.3
    return np.array([[ixx, off[0], off[1]], [off[0], iyy, off[2]], [off[1], off[2], izz]])


def build_pinocchio(params: ScaraParams, rng: np.random.Generator):  # noqa: ANN201
    """RZ, RZ, PZ, RZ with a rotation of π about x before joint 3 (z axes 3, 4 point down).

    Centres of mass lie along the links (bodies 1, 2) or on the quill axis (bodies 3, 4) at
    random heights, which must not change the joint efforts.
    """
    p = params
    model = pin.Model()
    model.gravity = pin.Motion(np.array([0.0, 0.0, -p.gravity]), np.zeros(3))
    identity = pin.SE3.Identity()
    j1 = model.addJoint(0, pin.JointModelRZ(), identity, 'joint1')
    model.appendBodyToJoint(j1, pin.Inertia(p.m1, np.array([p.lc1, 0.0, rng.uniform(-.1, .1)]),
                                            inertia_with_izz(rng, p.izz1)), identity)
    j2 = model.addJoint(j1, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([p.l1, 0.0, 0.0])),
                        'joint2')
    model.appendBodyToJoint(j2, pin.Inertia(p.m2, np.array([p.lc2, 0.0, rng.uniform(-.1, .1)]),
                                            inertia_with_izz(rng, p.izz2)), identity)
    flip = pin.utils.rotate('x', math.pi)
    j3 = model.addJoint(j2, pin.JointModelPZ(), pin.SE3(flip, np.array([p.l2, 0.0, 0.0])),
                        'joint3')
    model.appendBodyToJoint(j3, pin.Inertia(p.m3, np.array([0.0, 0.0, rng.uniform(-.2, .2)]),
                                            inertia_with_izz(rng, p.izz3)), identity)
    j4 = model.addJoint(j3, pin.JointModelRZ(), identity, 'joint4')
    model.appendBodyToJoint(j4, pin.Inertia(p.m4, np.array([0.0, 0.0, rng.uniform(0.0, .2)]),
                                            inertia_with_izz(rng, p.izz4)), identity)
    model.addFrame(pin.Frame('tool', j4, pin.SE3(np.eye(3), np.array([0.0, 0.0, p.d4])),
                             pin.FrameType.OP_FRAME))
    return model


def assert_close(ours: np.ndarray, ref: np.ndarray) -> None:
    """Agreement to 1e-9 relative to the size of the reference."""
    np.testing.assert_allclose(ours, ref, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(ref).max()))


@pytest.mark.parametrize('seed', range(5))
def test_agrees_with_pinocchio(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    params = random_params(rng) if seed else ScaraParams()
    ours = ScaraModel(params)
    ref = build_pinocchio(params, rng)
    data = ref.createData()
    tool = ref.getFrameId('tool')
    q, qd, qdd = random_states(rng, 20)
    energy_offset = None
    for i in range(len(q)):
        qi, vi, ai = q[i], qd[i], qdd[i]
        friction = ours.friction(vi)
        mass_ref = pin.crba(ref, data, qi)
        mass_ref = np.triu(mass_ref) + np.triu(mass_ref, 1).T   # in case upper only
        assert_close(ours.mass_matrix(qi), mass_ref)
        assert_close(ours.inverse_dynamics(qi, vi, ai),
                     pin.rnea(ref, data, qi, vi, ai) + friction)
        assert_close(ours.coriolis(qi, vi) + ours.gravity(qi),
                     pin.nonLinearEffects(ref, data, qi, vi))
        assert_close(ours.gravity(qi), pin.computeGeneralizedGravity(ref, data, qi))
        tau = rng.normal(0.0, 20.0, 4)
        assert_close(ours.forward_dynamics(qi, vi, tau),
                     pin.aba(ref, data, qi, vi, tau - friction))
        assert_close(ours.kinetic_energy(qi, vi), pin.computeKineticEnergy(ref, data, qi, vi))
        offset = pin.computePotentialEnergy(ref, data, qi) - ours.potential_energy(qi)
        energy_offset = offset if energy_offset is None else energy_offset
        assert math.isclose(offset, energy_offset, abs_tol=1e-9 * max(1.0, abs(offset)))
        pin.framesForwardKinematics(ref, data, qi)
        assert_close(ours.forward_kinematics(qi), data.oMf[tool].homogeneous)
