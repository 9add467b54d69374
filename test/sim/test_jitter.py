"""Jittered stamps: their statistics, and a simulated state that is the state at each stamp."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ParamError, ScaraParams
from scara_ident_ros.sim import SimConfig, Simulator, StampJitter, make_trajectory

PARAMS = ScaraParams()
TRAJ = make_trajectory('standard', PARAMS, seed=7)
PERIOD_NS = 2_000_000  # 500 Hz
JITTERED = SimConfig(dt=2e-3, jitter=2e-4, seed=3)  # 500 Hz, 0.2 ms standard deviation


def test_stamps_are_nominal_plus_clipped_seeded_offsets() -> None:
    jitter = StampJitter(PERIOD_NS, 2e-4, seed=1)
    stamps = jitter.stamps_ns(0, 20_000)
    offsets = stamps - np.arange(20_000) * PERIOD_NS
    assert stamps.dtype == np.int64
    assert offsets.std() == pytest.approx(2e5, rel=0.03)  # ns
    assert abs(offsets.mean()) < 5e3  # no drift: the mean period stays the nominal one
    assert np.abs(offsets).max() <= 6e5  # clipped at 3 standard deviations
    assert np.diff(stamps).min() > 0 and stamps[0] == 0
    # random access: one stamp at a time, any range, gives the same numbers
    assert [jitter.stamp_ns(k) for k in (5000, 3, 1023, 1024)] == stamps[[5000, 3, 1023,
                                                                          1024]].tolist()
    np.testing.assert_array_equal(jitter.stamps_ns(1000, 50), stamps[1000:1050])
    np.testing.assert_array_equal(StampJitter(PERIOD_NS, 2e-4, seed=1).stamps_ns(0, 100),
                                  stamps[:100])
    assert not np.array_equal(StampJitter(PERIOD_NS, 2e-4, seed=2).stamps_ns(0, 100),
                              stamps[:100])


def test_a_large_jitter_is_clipped_so_that_stamps_stay_in_order() -> None:
    stamps = StampJitter(PERIOD_NS, 1e-3, seed=0).stamps_ns(0, 10_000)  # std = T / 2
    offsets = stamps - np.arange(10_000) * PERIOD_NS
    assert np.abs(offsets).max() <= 0.45 * PERIOD_NS
    assert np.diff(stamps).min() >= 0.1 * PERIOD_NS
    assert StampJitter(PERIOD_NS, 0.0).stamps_ns(7, 3).tolist() == [14_000_000, 16_000_000,
                                                                    18_000_000]
    with pytest.raises(ValueError, match='jitter must be in'):
        StampJitter(PERIOD_NS, 1.1e-3)


def test_simulated_state_is_the_state_at_each_jittered_stamp() -> None:
    """q(t_{k+1}) − q(t_k) is the trapezoid of q' over the *jittered* interval.

    Within a step the effort is held, so q' is smooth there and the trapezoid rule's error
    is O(Δt³): a median of ~1e-7 (up to 2e-5 where Coulomb friction flips sign, as without
    jitter). Integrated over nominal steps instead, the state would be off by q'·Δe, a
    median of ~2e-4.
    """
    record = Simulator(PARAMS, TRAJ, JITTERED).simulate(3000)
    dt = np.diff(record.stamp_ns) * 1e-9  # s
    assert np.diff(record.stamp_ns).std() > 1e5  # jittered (ns)
    mean_velocity = 0.5 * (record.qd[1:] + record.qd[:-1])
    residual = np.abs(np.diff(record.q, axis=0) - mean_velocity * dt[:, None])
    assert np.median(residual) < 2e-7 and residual.max() < 5e-5
    nominal = np.abs(np.diff(record.q, axis=0) - mean_velocity * 2e-3)
    assert np.median(nominal) > 100 * np.median(residual)
    # the effort is the inverse dynamics of the reported state and acceleration
    tau = ScaraModel(PARAMS).inverse_dynamics(record.q, record.qd, record.qdd)
    np.testing.assert_allclose(record.effort, tau, rtol=1e-10, atol=1e-10 * np.abs(tau).max())
    # and the controller tracked the excitation at the jittered stamps
    q_des, _, _ = TRAJ.evaluate(record.stamp_ns * 1e-9)
    assert np.all(np.abs(record.q - q_des).max(axis=0) < [2e-3, 4e-3, 4e-4, 8e-3])


def test_jitter_is_seeded_and_zero_jitter_changes_nothing() -> None:
    record = Simulator(PARAMS, TRAJ, JITTERED).simulate(500)
    again = Simulator(PARAMS, TRAJ, JITTERED).simulate(500)
    np.testing.assert_array_equal(record.stamp_ns, again.stamp_ns)
    np.testing.assert_array_equal(record.q, again.q)
    other = Simulator(PARAMS, TRAJ, dataclasses.replace(JITTERED, seed=4)).simulate(500)
    assert not np.array_equal(other.stamp_ns, record.stamp_ns)
    plain = Simulator(PARAMS, TRAJ, SimConfig(dt=2e-3, seed=3)).simulate(500)
    zero = Simulator(PARAMS, TRAJ, SimConfig(dt=2e-3, seed=3, jitter=0.0)).simulate(500)
    np.testing.assert_array_equal(plain.stamp_ns, np.arange(500) * PERIOD_NS)
    np.testing.assert_array_equal(plain.q, zero.q)


@pytest.mark.parametrize(('jitter', 'fragment'), [
    (-1e-4, 'jitter must be >= 0'),
    (6e-4, r'jitter must be <= 0.5 dt = 0.0005 s'),
])
def test_bad_jitter_names_the_field(jitter: float, fragment: str) -> None:
    with pytest.raises(ParamError, match=fragment):
        SimConfig(jitter=jitter)
