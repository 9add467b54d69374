"""SequenceTrajectory: smooth joins, limits, determinism, and its use by the simulator."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraModel, ScaraParams
from scara_ident_ros.sim import (PRESETS, SEQUENCE, TRAJECTORIES, SequenceTrajectory, Simulator,
                                 make_trajectory)
from scara_ident_ros.sim.sequence import SEQUENCE_LIMITS

PARAMS = ScaraParams()
SEQ = make_trajectory(SEQUENCE, PARAMS, seed=5)
T = SEQ.period                       # s, one segment
BOUNDARIES = [k * T for k in range(1, 7)]


def assert_within_limits(trajectory: SequenceTrajectory, seconds: float,
                         limits: dict[str, float] = SEQUENCE_LIMITS) -> None:
    """Positions, speeds, accelerations and efforts within the margins, every ms."""
    t = np.linspace(0.0, seconds, round(seconds * 1000) + 1)
    q, qd, qdd = trajectory.evaluate(t)
    low, high = PARAMS.array('position_min'), PARAMS.array('position_max')
    margin = (1.0 - limits['position_fraction']) * 0.5 * (high - low)
    assert np.all(q >= low + margin * 0.999) and np.all(q <= high - margin * 0.999)
    assert np.all(np.abs(qd) <= limits['velocity_fraction'] * PARAMS.array('velocity_max')
                  * 1.001)
    assert np.all(np.abs(qdd) <= limits['acceleration_fraction']
                  * PARAMS.array('acceleration_max') * 1.001)
    tau = ScaraModel(PARAMS).inverse_dynamics(q[::5], qd[::5], qdd[::5])
    assert np.all(np.abs(tau) <= limits['effort_fraction'] * PARAMS.array('effort_max')
                  * 1.001)


def test_make_trajectory_builds_the_sequence_from_the_standard_settings() -> None:
    assert SEQUENCE in TRAJECTORIES and set(PRESETS) < set(TRAJECTORIES)
    assert isinstance(SEQ, SequenceTrajectory)
    assert T == pytest.approx(1.0 / PRESETS['standard']['base_frequency_hz'])
    assert SEQ.n_harmonics == PRESETS['standard']['n_harmonics']
    np.testing.assert_array_equal(SEQ.q0, PARAMS.position_centre)
    short = make_trajectory(SEQUENCE, PARAMS, seed=5, n_harmonics=3)
    assert short.n_harmonics == 3 and short.excitation(4).n_harmonics == 3


def test_evaluate_scalar_and_vector_shapes() -> None:
    q, qd, qdd = SEQ.evaluate(1.5)
    assert q.shape == qd.shape == qdd.shape == (4,)
    q, qd, qdd = SEQ.evaluate(np.linspace(0.0, 3 * T, 17))
    assert q.shape == qd.shape == qdd.shape == (17, 4)
    assert SEQ.grid().shape == (200 * SEQ.n_harmonics,)
    assert SEQ.grid(10, segments=3)[-1] < 3 * T
    assert all(peak.shape == (4,) for peak in SEQ.peaks(segments=2))
    for bad in (-1e-3, np.nan, np.zeros((2, 2))):
        with pytest.raises(ValueError, match='t must'):
            SEQ.evaluate(bad)


def test_the_first_segment_starts_on_the_first_excitation() -> None:
    for got, want in zip(SEQ.evaluate(0.0), SEQ.excitation(0).evaluate(0.0)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # and each segment ends on the next excitation's state
    for k in range(1, 4):
        for got, want in zip(SEQ.evaluate(k * T - 1e-12), SEQ.excitation(k).evaluate(0.0)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)


@pytest.mark.parametrize('boundary', BOUNDARIES)
def test_q_qd_qdd_are_continuous_across_segment_boundaries(boundary: float) -> None:
    # values just before and after the boundary agree
    before, after = SEQ.evaluate(boundary - 1e-9), SEQ.evaluate(boundary + 1e-9)
    for x_before, x_after in zip(before, after):
        np.testing.assert_allclose(x_before, x_after, rtol=0, atol=1e-6)
    # and q' is the derivative of q, q'' that of q', on points straddling the boundary
    # (a jump of q or q' would show as an error ~ jump / 2h, a jump of q'' ~ jump / 2)
    h = 1e-5                                                                  # s
    t = boundary + h * np.arange(-3, 4)
    q, qd, qdd = SEQ.evaluate(t)
    np.testing.assert_allclose((q[2:] - q[:-2]) / (2 * h), qd[1:-1], rtol=0, atol=1e-6)
    np.testing.assert_allclose((qd[2:] - qd[:-2]) / (2 * h), qdd[1:-1], rtol=0, atol=1e-4)


def test_derivatives_are_consistent_inside_segments() -> None:
    h = 1e-5
    t = np.array([0.3, 2.5, 4.1, 7.7, 13.2])
    q_p, qd_p, _ = SEQ.evaluate(t + h)
    q_m, qd_m, _ = SEQ.evaluate(t - h)
    _, qd, qdd = SEQ.evaluate(t)
    np.testing.assert_allclose((q_p - q_m) / (2 * h), qd, rtol=0, atol=1e-6)
    np.testing.assert_allclose((qd_p - qd_m) / (2 * h), qdd, rtol=0, atol=1e-4)


def test_stays_within_the_limits_over_a_minute() -> None:
    assert_within_limits(SEQ, 60.0)


def test_segments_leaving_the_limits_are_drawn_again() -> None:
    # excitations at the full 'standard' fractions: some blends would exceed the margins
    tight = SequenceTrajectory(PARAMS, seed=0, excitation=PRESETS['standard'])
    assert any(tight.attempt(k) > 0 for k in range(13))
    assert_within_limits(tight, 60.0)
    # and a redrawn excitation is the same whatever else was evaluated before
    again = SequenceTrajectory(PARAMS, seed=0, excitation=PRESETS['standard'])
    k = next(k for k in range(13) if tight.attempt(k) > 0)
    np.testing.assert_array_equal(again.excitation(k).a, tight.excitation(k).a)


def test_impossible_limits_fail_with_a_message() -> None:
    # gravity alone needs more than 5 % of joint 3's force limit
    limits = {**SEQUENCE_LIMITS, 'effort_fraction': 0.05}
    sequence = SequenceTrajectory(PARAMS, seed=0, limit_fractions=limits, max_attempts=3)
    with pytest.raises(ValueError, match='no excitation 1 of 3 candidates'):
        sequence.evaluate(0.0)
    with pytest.raises(ValueError, match='limit_fractions'):
        SequenceTrajectory(PARAMS, seed=0, limit_fractions={'position_fraction': 0.5})
    with pytest.raises(ValueError, match='seed'):
        SequenceTrajectory(PARAMS, seed=-1)


def test_equal_seeds_give_equal_sequences_whatever_the_evaluation_order() -> None:
    t = np.linspace(0.0, 40.0, 4001)
    forward = make_trajectory(SEQUENCE, PARAMS, seed=9)
    expected = forward.evaluate(t)
    # another instance, with a cache too small to keep anything, evaluated backwards
    # and then in a random order
    backward = SequenceTrajectory(PARAMS, seed=9, cache_size=2)
    got = [np.empty_like(x) for x in expected]
    for i in range(len(t) - 1, -1, -1):
        for out, value in zip(got, backward.evaluate(t[i])):
            out[i] = value
    for x_got, x_want in zip(got, expected):
        np.testing.assert_allclose(x_got, x_want, rtol=0, atol=1e-12)
    order = np.random.default_rng(0).permutation(len(t))
    shuffled = SequenceTrajectory(PARAMS, seed=9).evaluate(t[order])
    for x_got, x_want in zip(shuffled, expected):
        np.testing.assert_allclose(x_got, x_want[order], rtol=0, atol=1e-12)
    for k in range(9):
        np.testing.assert_array_equal(backward.excitation(k).a, forward.excitation(k).a)
        np.testing.assert_array_equal(backward.excitation(k).b, forward.excitation(k).b)


def test_different_seeds_give_different_sequences() -> None:
    other = make_trajectory(SEQUENCE, PARAMS, seed=6)
    t = np.linspace(0.0, 20.0, 101)
    assert not np.allclose(other.evaluate(t)[0], SEQ.evaluate(t)[0])


def test_segments_differ_from_each_other() -> None:
    excitations = [SEQ.excitation(k) for k in range(8)]
    for i, first in enumerate(excitations):
        for second in excitations[i + 1:]:
            assert not np.allclose(first.a, second.a)
    # the motion itself does not repeat from one segment to the next
    u = np.linspace(0.0, T, 50, endpoint=False)
    segments = [SEQ.evaluate(k * T + u)[0] for k in range(6)]
    for i in range(len(segments) - 1):
        assert np.abs(segments[i + 1] - segments[i]).max() > 0.05


@pytest.mark.parametrize('start', [T - 0.5, 3 * T - 1.0, 2 * T + 1e-3])
def test_chunks_straddling_a_boundary_equal_pointwise_evaluation(start: float) -> None:
    times = start + np.arange(1024) * 1e-3          # the simulator's chunks of 1024 samples
    q, qd, qdd = SEQ.evaluate(times)
    for i in range(0, len(times), 37):
        for chunk, point in zip((q[i], qd[i], qdd[i]), SEQ.evaluate(float(times[i]))):
            np.testing.assert_allclose(chunk, point, rtol=0, atol=1e-12)


def test_simulator_tracks_the_sequence_across_a_boundary() -> None:
    trajectory = make_trajectory(SEQUENCE, PARAMS, seed=2)
    record = Simulator(PARAMS, trajectory).simulate(round(1.5 * T * 1000))
    q_des, _, _ = trajectory.evaluate(record.stamp_ns * 1e-9)
    # as close as on one excitation (test_simulator.py), the join at T included
    assert np.all(np.abs(record.q - q_des).max(axis=0) < [2e-3, 4e-3, 2e-4, 4e-3])
    assert np.all(np.abs(record.effort) <= np.array(PARAMS.effort_max) * (1 + 1e-12))
