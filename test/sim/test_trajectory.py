"""Tests of the Fourier-series excitation trajectories."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ScaraParams
from scara_ident_ros.sim.registry import TRAJECTORIES, make_trajectory
from scara_ident_ros.sim.trajectory import PRESETS, FourierTrajectory

PARAMS = ScaraParams()


def test_evaluate_scalar_and_vector_shapes() -> None:
    traj = make_trajectory('gentle', PARAMS, seed=0)
    q, qd, qdd = traj.evaluate(0.3)
    assert q.shape == qd.shape == qdd.shape == (4,)
    qs, qds, qdds = traj.evaluate(np.array([0.0, 0.3, 1.0]))
    assert qs.shape == qds.shape == qdds.shape == (3, 4)
    np.testing.assert_allclose(qs[1], q, rtol=1e-15)
    np.testing.assert_allclose(qdds[1], qdd, rtol=1e-15)


def test_series_matches_the_formula() -> None:
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    q0 = rng.normal(size=4)
    traj = FourierTrajectory(q0, a, b, base_frequency_hz=0.25)
    t = 1.7
    wf = 2 * np.pi * 0.25
    q, qd, _ = traj.evaluate(t)
    for i in range(4):
        expected = q0[i] + sum(a[i, k] / (wf * (k + 1)) * np.sin(wf * (k + 1) * t)
                               - b[i, k] / (wf * (k + 1)) * np.cos(wf * (k + 1) * t)
                               for k in range(3))
        assert q[i] == pytest.approx(expected, rel=1e-13)
    assert traj.period == pytest.approx(4.0)
    assert traj.n_harmonics == 3


def test_derivatives_are_consistent() -> None:
    traj = make_trajectory('aggressive', PARAMS, seed=2)
    t = np.linspace(0.0, traj.period, 101)
    h = 1e-5
    q_p, qd_p, _ = traj.evaluate(t + h)
    q_m, qd_m, _ = traj.evaluate(t - h)
    _, qd, qdd = traj.evaluate(t)
    np.testing.assert_allclose((q_p - q_m) / (2 * h), qd, atol=1e-6 * np.abs(qd).max())
    np.testing.assert_allclose((qd_p - qd_m) / (2 * h), qdd, atol=1e-6 * np.abs(qdd).max())


def test_periodic_with_mean_q0() -> None:
    traj = make_trajectory('standard', PARAMS, seed=3)
    for x0, x1 in zip(traj.evaluate(0.0), traj.evaluate(traj.period)):
        np.testing.assert_allclose(x0, x1, atol=1e-10)
    q, _, _ = traj.evaluate(traj.grid())
    np.testing.assert_allclose(q.mean(axis=0), PARAMS.position_centre, atol=1e-12)


@pytest.mark.parametrize('preset', sorted(PRESETS))
@pytest.mark.parametrize('seed', range(3))
def test_random_stays_inside_limits_on_a_dense_grid(preset: str, seed: int) -> None:
    traj = make_trajectory(preset, PARAMS, seed=seed)
    settings = PRESETS[preset]
    t = np.linspace(0.0, traj.period, 20001)
    q, qd, qdd = traj.evaluate(t)
    low, high = PARAMS.array('position_min'), PARAMS.array('position_max')
    margin = (1.0 - settings['position_fraction']) * 0.5 * (high - low)
    assert np.all(q >= low + margin * 0.999) and np.all(q <= high - margin * 0.999)
    v_max = settings['velocity_fraction'] * PARAMS.array('velocity_max')
    a_max = settings['acceleration_fraction'] * PARAMS.array('acceleration_max')
    assert np.all(np.abs(qd) <= v_max * 1.001)
    assert np.all(np.abs(qdd) <= a_max * 1.001)
    tau = ScaraModel(PARAMS).inverse_dynamics(q[::10], qd[::10], qdd[::10])
    assert np.all(np.abs(tau) <= settings['effort_fraction'] * PARAMS.array('effort_max')
                  * 1.001)
    # every joint uses a good part of one of its limits: the excitation is not trivial
    excursion, speed, accel = traj.peaks()
    assert np.all(np.maximum.reduce([excursion / (0.5 * (high - low)),
                                     speed / PARAMS.array('velocity_max'),
                                     accel / PARAMS.array('acceleration_max')]) > 0.1)


def test_random_is_deterministic_per_seed() -> None:
    a = make_trajectory('standard', PARAMS, seed=11)
    b = make_trajectory('standard', PARAMS, seed=11)
    c = make_trajectory('standard', PARAMS, seed=12)
    np.testing.assert_array_equal(a.a, b.a)
    np.testing.assert_array_equal(a.b, b.b)
    assert not np.array_equal(a.a, c.a)


def test_unknown_preset_lists_the_known_ones() -> None:
    assert TRAJECTORIES == (*PRESETS, 'sequence')
    with pytest.raises(ValueError, match='aggressive, gentle, sequence, standard'):
        make_trajectory('wild', PARAMS, seed=0)


def test_overrides_and_invalid_settings() -> None:
    traj = make_trajectory('gentle', PARAMS, seed=0, n_harmonics=2)
    assert traj.n_harmonics == 2
    with pytest.raises(ValueError, match='velocity_fraction'):
        FourierTrajectory.random(PARAMS, seed=0, velocity_fraction=1.5)
    with pytest.raises(ValueError, match='n_harmonics'):
        FourierTrajectory.random(PARAMS, seed=0, n_harmonics=0)
    with pytest.raises(ValueError, match='effort'):
        # gravity alone needs more than this fraction of joint 3's force limit
        FourierTrajectory.random(ScaraParams(effort_max=(250.0, 100.0, 50.0, 10.0)), seed=0,
                                 effort_fraction=0.5)
    with pytest.raises(ValueError, match='base_frequency_hz'):
        FourierTrajectory(np.zeros(4), np.ones((4, 2)), np.ones((4, 2)), 0.0)
    with pytest.raises(ValueError, match=r'\(4, L\)'):
        FourierTrajectory(np.zeros(4), np.ones((3, 2)), np.ones((3, 2)), 1.0)
    traj = make_trajectory('gentle', PARAMS, seed=0)
    with pytest.raises(ValueError):
        traj.q0[0] = 1.0                  # coefficients are read-only
