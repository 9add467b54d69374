"""Tests of the simulator: tracking, determinism, stamps, consistency, configuration."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ParamError, ScaraParams
from scara_ident_ros.sim.simulator import SimConfig, SimRecord, SimSample, Simulator
from scara_ident_ros.sim.registry import make_trajectory

PARAMS = ScaraParams()
TRAJ = make_trajectory('standard', PARAMS, seed=7)
NOISY = SimConfig(position_noise=1e-4, velocity_noise=1e-3,
                  effort_noise=(0.5, 0.2, 0.5, 0.02), disturbance=0.01,
                  disturbance_kind='random', seed=5)


def test_step_returns_a_sample_starting_on_the_trajectory() -> None:
    sim = Simulator(PARAMS, TRAJ)
    sample = sim.step()
    assert isinstance(sample, SimSample)
    assert sample.stamp_ns == 0 and isinstance(sample.stamp_ns, int)
    for array in (sample.q, sample.qd, sample.qdd, sample.effort):
        assert array.shape == (4,) and array.dtype == np.float64
    q0, qd0, _ = TRAJ.evaluate(0.0)
    np.testing.assert_array_equal(sample.q, q0)
    np.testing.assert_array_equal(sample.qd, qd0)
    assert sim.step().stamp_ns == 1_000_000


def test_controller_tracks_the_excitation() -> None:
    sim = Simulator(PARAMS, TRAJ)
    record = sim.simulate(3000)                       # 3 s
    q_des, qd_des, _ = TRAJ.evaluate(record.stamp_ns * 1e-9)
    # perfect model: what is left comes from holding the effort over each 1 ms step,
    # mostly the Coulomb compensation of the light wrist around velocity reversals
    assert np.all(np.abs(record.q - q_des).max(axis=0) < [1e-3, 2e-3, 2e-4, 4e-3])
    assert np.all(np.abs(record.qd - qd_des).max(axis=0) < [0.02, 0.05, 0.002, 0.1])
    # with a 10 % model error, noise and a random disturbance the PD loop still follows
    cfg = dataclasses.replace(NOISY, model_mismatch=0.1)
    record = Simulator(PARAMS, TRAJ, cfg).simulate(3000)
    q_des, _, _ = TRAJ.evaluate(record.stamp_ns * 1e-9)
    amplitude = np.ptp(q_des, axis=0)
    assert np.all(np.abs(record.q - q_des).max(axis=0) < 0.05 * amplitude)


def test_simulate_equals_repeated_steps_and_is_deterministic() -> None:
    record = Simulator(PARAMS, TRAJ, NOISY).simulate(200)
    assert isinstance(record, SimRecord) and len(record) == 200
    sim = Simulator(PARAMS, TRAJ, NOISY)
    samples = [sim.step() for _ in range(200)]
    np.testing.assert_array_equal(record.stamp_ns, [s.stamp_ns for s in samples])
    for name in ('q', 'qd', 'qdd', 'effort'):
        np.testing.assert_array_equal(getattr(record, name),
                                      np.array([getattr(s, name) for s in samples]))
    sim.reset()
    again = sim.simulate(200)
    np.testing.assert_array_equal(again.effort, record.effort)
    other = Simulator(PARAMS, TRAJ, dataclasses.replace(NOISY, seed=6)).simulate(200)
    assert not np.array_equal(other.q, record.q)


@pytest.mark.parametrize('dt', [1e-3, 4e-3, 1 / 1024])
def test_stamps_are_exact_integers(dt: float) -> None:
    dt = round(dt * 1e9) * 1e-9 if dt == 1 / 1024 else dt
    sim = Simulator(PARAMS, TRAJ, SimConfig(dt=dt))
    record = sim.simulate(100)
    assert record.stamp_ns.dtype == np.int64
    np.testing.assert_array_equal(record.stamp_ns, np.arange(100) * round(dt * 1e9))
    assert sim.stamp_ns == 100 * round(dt * 1e9)


def test_noise_free_effort_is_inverse_dynamics_of_the_true_state() -> None:
    record = Simulator(PARAMS, TRAJ).simulate(500)
    tau = ScaraModel(PARAMS).inverse_dynamics(record.q, record.qd, record.qdd)
    np.testing.assert_allclose(record.effort, tau, rtol=1e-10,
                               atol=1e-10 * np.abs(tau).max())


def test_integration_is_converged() -> None:
    """RK4 substeps: fourth-order convergence, default within 1e-7 of a fine reference."""
    fine = Simulator(PARAMS, TRAJ, SimConfig(substeps=32)).simulate(1000)
    errors = []
    for substeps in (1, 2, 4):
        run = Simulator(PARAMS, TRAJ, SimConfig(substeps=substeps)).simulate(1000)
        errors.append(np.abs(run.qd - fine.qd).max())
        if substeps == SimConfig().substeps:
            np.testing.assert_allclose(run.q, fine.q, rtol=0, atol=1e-7)
            np.testing.assert_allclose(run.qd, fine.qd, rtol=0, atol=1e-5)
    assert errors[0] / errors[1] > 8 and errors[1] / errors[2] > 8


def test_disturbance_enters_eq6_on_the_left() -> None:
    """M q'' + C q' + F + G + T_d = tau, so tau − ID(q, q', q'') = T_d."""
    for kind in ('sinusoid', 'random'):
        sim = Simulator(PARAMS, TRAJ, SimConfig(disturbance=0.01, disturbance_kind=kind,
                                                seed=3))
        model = ScaraModel(PARAMS)
        dist, residual = [], []
        for _ in range(300):
            dist.append(sim.disturbance())
            s = sim.step()
            residual.append(s.effort - model.inverse_dynamics(s.q, s.qd, s.qdd))
        np.testing.assert_allclose(residual, dist, atol=1e-9)
        peak, amplitude = np.abs(dist).max(axis=0), 0.01 * np.array(PARAMS.effort_max)
        if kind == 'sinusoid':          # 0.3 s of a 0.5 Hz sine spans at least 54 degrees
            assert np.all(peak <= amplitude * (1 + 1e-12)) and np.all(peak > 0.4 * amplitude)
        else:
            assert np.all(peak > 0.0) and np.all(peak < 6.0 * amplitude)
    sim = Simulator(PARAMS, TRAJ, SimConfig(disturbance=0.0, disturbance_kind='random'))
    np.testing.assert_array_equal(sim.disturbance(), 0.0)


def test_noise_is_on_the_readings_not_on_the_state() -> None:
    sim = Simulator(PARAMS, TRAJ, NOISY)
    truth, readings = [], []
    for _ in range(2000):
        truth.append(np.concatenate(sim.state))
        s = sim.step()
        readings.append(np.concatenate([s.q, s.qd]))
    error = np.array(readings) - np.array(truth)
    np.testing.assert_allclose(error.std(axis=0), [1e-4] * 4 + [1e-3] * 4, rtol=0.1)
    assert np.abs(error.mean(axis=0)).max() < 1e-4


def test_effort_noise_is_on_the_reported_effort_only() -> None:
    """effort = tau + noise, where tau - T_d = ID(true q, q', q'') drove the plant."""
    sim = Simulator(PARAMS, TRAJ, NOISY)
    model = ScaraModel(PARAMS)
    noise = []
    for _ in range(2000):
        q, qd = sim.state
        disturbance = sim.disturbance()
        s = sim.step()
        noise.append(s.effort - model.inverse_dynamics(q, qd, s.qdd) - disturbance)
    noise = np.array(noise)
    np.testing.assert_allclose(noise.std(axis=0), NOISY.effort_noise, rtol=0.1)
    assert (np.abs(noise.mean(axis=0)) < 0.1 * np.array(NOISY.effort_noise)).all()


def test_efforts_never_exceed_the_limits() -> None:
    weak = dataclasses.replace(PARAMS, effort_max=(20.0, 10.0, 60.0, 1.0))
    record = Simulator(weak, TRAJ).simulate(1000)
    assert np.all(np.abs(record.effort) <= np.array(weak.effort_max))
    assert np.any(np.abs(record.effort) == np.array(weak.effort_max))   # it did saturate


@pytest.mark.parametrize(('changes', 'fragment'), [
    ({'dt': 0.0}, 'dt must be > 0, got 0.0'),
    ({'dt': -1e-3}, 'dt must be > 0'),
    ({'dt': 1e-3 / 3}, 'dt must be a whole number of nanoseconds'),
    ({'substeps': 0}, 'substeps must be >= 1'),
    ({'substeps': 2.5}, 'substeps must be an integer'),
    ({'kp': -5.0}, r'kp\[0\] must be > 0'),
    ({'kd': (1.0, 2.0)}, 'kd must have 4 values'),
    ({'position_noise': -1e-3}, r'position_noise\[0\] must be >= 0'),
    ({'effort_noise': (0.1, 0.1, 0.1)}, 'effort_noise must have 4 values'),
    ({'disturbance': -0.1}, 'disturbance must be >= 0'),
    ({'disturbance': 1.5}, 'disturbance must be <= 1'),
    ({'disturbance': 'random'}, 'disturbance must be a number'),
    ({'disturbance_kind': 'gusts'}, 'disturbance_kind must be one of sinusoid, random'),
    ({'disturbance_frequency_hz': 0.0}, 'disturbance_frequency_hz must be > 0'),
    ({'model_mismatch': 1.0}, 'model_mismatch must be < 1'),
    ({'seed': -1}, 'seed must be >= 0'),
])
def test_bad_config_names_the_field(changes: dict, fragment: str) -> None:
    with pytest.raises(ParamError, match=fragment):
        SimConfig(**changes)


def test_config_dict_round_trip_and_unknown_keys() -> None:
    assert SimConfig.from_dict(NOISY.to_dict()) == NOISY
    assert SimConfig(kp=100.0).kp == (100.0,) * 4
    assert SimConfig().dt_ns == 1_000_000
    with pytest.raises(ParamError, match='rate_hz'):
        SimConfig.from_dict({'rate_hz': 1000})


def test_simulate_rejects_negative_counts() -> None:
    assert len(Simulator(PARAMS, TRAJ).simulate(0)) == 0
    with pytest.raises(ParamError, match='n must be >= 0'):
        Simulator(PARAMS, TRAJ).simulate(-1)


def test_external_effort_enters_the_dynamics_not_the_reported_effort() -> None:
    """τ_ext is a load on the joints: the true q'' obeys M q'' + ... = τ − τ_ext, the
    reported effort stays the actuators' τ (so measured − ID(q, q', q'') = τ_ext), the arm
    deviates and the controller reacts; None ends it."""
    model = ScaraModel(PARAMS)
    free, pushed = Simulator(PARAMS, TRAJ), Simulator(PARAMS, TRAJ)
    free.simulate(100)
    pushed.simulate(100)
    external = np.array([20.0, 0.0, 0.0, -0.5])  # N·m, N·m, N, N·m
    pushed.apply_external(external)
    np.testing.assert_array_equal(pushed.external, external)
    first = pushed.step()
    np.testing.assert_allclose(
        first.effort - model.inverse_dynamics(first.q, first.qd, first.qdd), external,
        atol=1e-9)
    np.testing.assert_allclose(first.effort, free.step().effort)  # nothing reacted yet
    for _ in range(20):
        later, reference = pushed.step(), free.step()
    assert abs(later.q[0] - reference.q[0]) > 1e-4  # the arm gave way
    assert later.effort[0] - reference.effort[0] > 1.0  # the controller pushes back
    pushed.apply_external(None)
    sample = pushed.step()
    np.testing.assert_allclose(
        sample.effort, model.inverse_dynamics(sample.q, sample.qd, sample.qdd), atol=1e-9)
    with pytest.raises(ValueError):
        pushed.apply_external([1.0, 2.0])
