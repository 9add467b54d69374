"""The one sample-to-input stage: zero-phase q'', its lag, gaps, edges and counting."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.identification import (CentredDifferentiator, Differentiator, InputStage,
                                            JointMap, SkipReason)

NAMES = ('a', 'b')
MS = 1_000_000  # ns
T0 = 1_700_000_000_000_000_000  # ns


def jittered_stamps(count: int, seed: int = 0) -> np.ndarray:
    """1 kHz stamps with up to ±0.3 ms of jitter, increasing."""
    rng = np.random.default_rng(seed)
    return T0 + np.arange(count) * MS + rng.integers(-300_000, 300_000, count)


@pytest.mark.parametrize('degree', [1, 2, 3])
def test_centred_estimate_is_exact_on_polynomials_of_its_degree(degree: int) -> None:
    stamps = jittered_stamps(200)
    t = (stamps - T0) * 1e-9  # s
    coef = np.array([0.3, -1.2, 2.5, -4.0])[:degree + 1]
    velocity = np.polynomial.polynomial.polyval(t, coef)[:, None] * [1.0, -2.0]
    truth = np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyder(coef))
    stage = InputStage(JointMap(NAMES, n_joints=2), need_effort=False,
                       differentiator=CentredDifferentiator(21, degree))
    out, X, _ = stage.batch(stamps, NAMES, np.zeros((200, 2)), velocity)
    np.testing.assert_array_equal(out, stamps)  # every sample, the edges included
    np.testing.assert_allclose(X[:, 4], truth, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(X[:, 5], -2.0 * truth, rtol=1e-6, atol=1e-6)


def test_centred_estimate_has_no_lag_where_the_lowpass_has_three_ms() -> None:
    stamps = T0 + np.arange(2000) * MS
    t = np.arange(2000) * 1e-3
    omega = 2 * np.pi * 2.0  # 2 Hz
    velocity = np.sin(omega * t)[:, None]
    truth = omega * np.cos(omega * t)
    errors = {}
    for estimate in (CentredDifferentiator(), Differentiator('lowpass', cutoff_hz=50.0)):
        stage = InputStage(JointMap(('a',), n_joints=1), need_effort=False,
                           differentiator=estimate)
        out, X, _ = stage.batch(stamps, ('a',), np.zeros((2000, 1)), velocity)
        rows = np.searchsorted(stamps, out)
        errors[type(estimate).__name__] = np.abs(X[:, 2] - truth[rows])[100:-100].max()
    # bias (2 pi f m T)^2 / 10 = 1.6e-3 relative at 2 Hz with W = 21 (module docstring)
    assert errors['CentredDifferentiator'] < 2.5e-3 * omega
    assert errors['Differentiator'] > 20 * errors['CentredDifferentiator']


def test_lag_counts_and_gap_flush() -> None:
    stage = InputStage(JointMap(NAMES, n_joints=2), max_gap_ns=20 * MS)
    assert stage.lag == 10
    out = []
    for k in range(30):
        reason, ready = stage.push(T0 + k * MS, NAMES, [k, 0.0], [0.0, 1.0], [1.0, 2.0])
        assert reason is None
        out += ready
        # the first full window lets out its first half and its centre, then one per sample
        assert len(ready) == (0 if k < 20 else 11 if k == 20 else 1)
        assert stage.pending == (k + 1 if k < 20 else 10)
    assert [item.stamp_ns for item in out] == [T0 + k * MS for k in range(20)]
    # A gap lets the last 10 samples of the history out before the new history starts.
    reason, ready = stage.push(T0 + 100 * MS, NAMES, [0.0, 0.0], [0.0, 1.0], [1.0, 2.0])
    assert reason is None and [item.stamp_ns for item in ready] == [T0 + k * MS
                                                                    for k in range(20, 30)]
    assert stage.pending == 1
    # A rejected sample changes nothing; a history shorter than the window is dropped.
    assert stage.push(T0 + 101 * MS, NAMES, [np.nan, 0.0], [0.0, 1.0], [1.0, 2.0]) == \
        (SkipReason.NON_FINITE, [])
    assert stage.push(T0 + 101 * MS, NAMES, [0.0, 0.0], [0.0, 1.0], [1.0, 2.0]) == \
        (SkipReason.REPEATED, [])  # the state at 100 ms sent again
    stage.push(T0 + 101 * MS, NAMES, [0.5, 0.0], [0.0, 1.0], [1.0, 2.0])
    assert stage.flush() == [] and stage.pending == 0
    assert stage.emitted == 30
    assert stage.skipped[SkipReason.WARMING_UP] == 2 and stage.skipped[SkipReason.NON_FINITE] == 1
    assert stage.skipped[SkipReason.REPEATED] == 1


def test_reordered_joints_come_out_in_joint_order() -> None:
    stage = InputStage(JointMap(NAMES, n_joints=2), differentiator=Differentiator('backward'))
    stage.push(T0, ('b', 'a'), [2.0, 1.0], [20.0, 10.0], [200.0, 100.0])
    reason, (item,) = stage.push(T0 + MS, ('b', 'a'), [2.0, 1.0], [21.0, 11.0],
                                 [200.0, 100.0])
    assert reason is None
    np.testing.assert_allclose(item.x, [1.0, 2.0, 11.0, 21.0, 1000.0, 1000.0])
    np.testing.assert_array_equal(item.effort, [100.0, 200.0])


def test_centred_acceleration_on_uneven_stamps_matches_the_analytic_derivative() -> None:
    """Steps of 0.7 to 8.8 ms around a nominal 1 kHz (a real arm's): q'' of a 1 Hz motion
    within 0.5 % of its amplitude, at every sample (no gap: 8.8 ms is below max_gap)."""
    rng = np.random.default_rng(3)
    steps = rng.uniform(0.7, 1.3, 3999) * MS
    steps[rng.choice(3999, 80, replace=False)] = rng.uniform(3.0, 8.8, 80) * MS
    stamps = T0 + np.concatenate(([0], np.cumsum(steps))).astype(np.int64)
    t = (stamps - T0) * 1e-9
    omega = 2 * np.pi * 1.0
    velocity = np.column_stack([np.sin(omega * t), 0.5 * np.cos(omega * t)])
    truth = np.column_stack([omega * np.cos(omega * t), -0.5 * omega * np.sin(omega * t)])
    stage = InputStage(JointMap(NAMES, n_joints=2), need_effort=False)
    out, X, _ = stage.batch(stamps, NAMES, np.zeros((4000, 2)), velocity)
    np.testing.assert_array_equal(out, stamps)
    assert stage.gaps == 0
    np.testing.assert_allclose(X[:, 4:], truth, atol=5e-3 * omega)


# ------------------------------------------------------------ q' derived from q
def test_centred_stage_derives_velocity_and_acceleration_of_cubic_positions() -> None:
    """No velocity in the stream: q' and q'' from one cubic fit of q, exact for cubic q on
    jittered stamps, every sample out (none ``no_velocity``)."""
    stamps = jittered_stamps(200)
    t = (stamps - T0) * 1e-9  # s
    coef = np.array([0.3, -1.2, 2.5, -4.0])
    q = np.polynomial.polynomial.polyval(t, coef)[:, None] * [1.0, -2.0]
    qd = np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyder(coef))
    qdd = np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyder(coef, 2))
    stage = InputStage(JointMap(NAMES, n_joints=2), need_effort=False, derive_velocity=True)
    out, X, _ = stage.batch(stamps, NAMES, q, np.zeros((200, 0)))
    np.testing.assert_array_equal(out, stamps)
    assert stage.skipped[SkipReason.NO_VELOCITY] == 0 and stage.deriving
    np.testing.assert_allclose(X[:, 2], qd, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(X[:, 3], -2.0 * qd, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(X[:, 4], qdd, rtol=1e-5, atol=1e-5)


def test_without_derive_velocity_a_stream_without_velocity_is_skipped() -> None:
    stamps = T0 + np.arange(50) * MS
    stage = InputStage(JointMap(NAMES, n_joints=2), need_effort=False)
    out, _, _ = stage.batch(stamps, NAMES, np.zeros((50, 2)), np.zeros((50, 0)))
    assert out.size == 0 and stage.skipped[SkipReason.NO_VELOCITY] == 50


def test_causal_stage_derives_velocity_of_a_ramp_and_counts_repeats() -> None:
    """Backward differences of q = 0.5 t: q' = 0.5, q'' = 0 once warmed up; a row whose q
    and effort equal the last one's is ``repeated``, not learnt again."""
    stamps = T0 + np.arange(40) * MS
    q = 0.5 * np.arange(40)[:, None] * 1e-3 * [1.0, 1.0]
    effort = np.arange(40)[:, None] * [1.0, 2.0]
    q[20], effort[20] = q[19], effort[19]  # the driver sent its last state again
    stage = InputStage(JointMap(NAMES, n_joints=2), need_effort=False, derive_velocity=True,
                       differentiator=Differentiator('backward'))
    out, X, _ = stage.batch(stamps, NAMES, q, np.zeros((40, 0)), effort)
    assert stage.skipped[SkipReason.REPEATED] == 1
    assert out.size + sum(stage.skipped.values()) == 40  # every sample accounted for
    steady = out > stamps[22]  # two samples after the repeat: the backward difference again
    np.testing.assert_allclose(X[steady, 2:4], 0.5, rtol=1e-9)
    np.testing.assert_allclose(X[steady, 4:], 0.0, atol=1e-9)


def test_a_window_of_three_derives_nothing_but_builds() -> None:
    stage = InputStage(JointMap(NAMES, n_joints=2), need_effort=False, derive_velocity=True,
                       differentiator=CentredDifferentiator(3, 1))
    assert not stage.derive_velocity
    assert stage.push(T0, NAMES, [0.0, 0.0], [])[0] is SkipReason.NO_VELOCITY
