"""Tests of the online identifier with a fake model that records what it was trained on."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np
import pytest
from numpy.typing import NDArray

from scara_ident_ros.identification import (Differentiator, OnlineIdentifier, SkipReason,
                                            StepResult)

NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
N = len(NAMES)
T0 = 1_700_000_000_000_000_000  # ns
MS = 1_000_000  # ns
NAN, INF = math.nan, math.inf


@dataclass
class RecordingModel:
    """A linear model y = W x trained by SGD, recording every call in order."""

    n_outputs: int = N
    rate: float = 1e-3
    events: list[tuple[str, NDArray[np.float64], NDArray[np.float64]]] = field(
        default_factory=list)

    def __post_init__(self) -> None:
        self.n_inputs = 3 * self.n_outputs
        self.weights = np.random.default_rng(0).normal(0.0, 0.1, (self.n_outputs,
                                                                  self.n_inputs))

    def predict(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        # Records the weights the prediction was computed with.
        self.events.append(('predict', X.copy(), self.weights.copy()))
        return X @ self.weights.T

    def partial_fit(self, X: NDArray[np.float64],
                    Y: NDArray[np.float64]) -> NDArray[np.float64]:
        assert X.ndim == 2 and Y.ndim == 2
        # The a-priori prediction inside the step, recorded as a 'predict' event with
        # the weights it was computed with, then the step itself.
        errors = Y - X @ self.weights.T
        self.events.append(('predict', X[0].copy(), self.weights.copy()))
        self.events.append(('fit', X.copy(), Y.copy()))
        for x, y in zip(X, Y, strict=True):
            self.weights -= self.rate * np.outer(x @ self.weights.T - y, x)
        return errors

    def fits(self) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        return [(x, y) for kind, x, y in self.events if kind == 'fit']


def state(k: int) -> tuple[list[float], list[float], list[float]]:
    """Good joint values of sample k, in joint order: q, qd linear in k (so qdd is exact)."""
    q = [0.1 * k + j for j in range(N)]
    qd = [0.5 * j + 0.001 * k * (j + 1) for j in range(N)]  # qdd = (j + 1) units per second
    effort = [10.0 * j - 0.01 * k for j in range(N)]
    return q, qd, effort


def message(k: int, order: Sequence[int] = range(N)) -> tuple[list[str], list[float],
                                                              list[float], list[float]]:
    """Sample k as a message with the joints in ``order``."""
    q, qd, effort = state(k)
    return ([NAMES[j] for j in order], [q[j] for j in order], [qd[j] for j in order],
            [effort[j] for j in order])


def expected_x(k: int) -> NDArray[np.float64]:
    q, qd, _ = state(k)
    return np.array(q + qd + [float(j + 1) for j in range(N)])


def one(results: list[StepResult]) -> StepResult:
    """The one result of a sample with a causal differentiator (lag 0)."""
    assert len(results) == 1
    return results[0]


def make(model: RecordingModel, **kwargs: object) -> OnlineIdentifier:
    kwargs.setdefault('joint_names', NAMES)
    kwargs.setdefault('differentiator', Differentiator('backward'))
    kwargs.setdefault('max_gap_ns', 50 * MS)
    return OnlineIdentifier(model, **kwargs)  # type: ignore[arg-type]


def test_hostile_stream() -> None:
    model = RecordingModel()
    ident = make(model)
    good: list[int] = []  # sample indices the model must learn from, in order

    def feed(stamp: int, msg: tuple[list[str], list[float], list[float], list[float]],
             expect: SkipReason | None, k: int | None = None) -> StepResult:
        result = one(ident.process(stamp, *msg))
        assert result.reason is expect and result.stamp_ns == stamp
        assert (result.effort is None) == (expect is not None)
        if expect is None:
            assert k is not None
            good.append(k)
        return result

    def bad(k: int, field_: int, value: float) -> tuple[list[str], list[float], list[float],
                                                        list[float]]:
        """Sample k with joint3's position (1), velocity (2) or effort (3) set to value."""
        names, *values = message(k)
        values[field_ - 1][2] = value
        return names, values[0], values[1], values[2]

    names, q, qd, eff = message(0)
    feed(T0, (names, q, qd, eff), SkipReason.WARMING_UP)
    feed(T0 + MS, message(1), None, 1)
    feed(T0 + 2 * MS, bad(2, 1, NAN), SkipReason.NON_FINITE)
    feed(T0 + 2 * MS, bad(2, 2, NAN), SkipReason.NON_FINITE)  # NaN velocity: must not poison
    feed(T0 + 2 * MS, bad(2, 2, -INF), SkipReason.NON_FINITE)
    feed(T0 + 2 * MS, bad(2, 3, INF), SkipReason.NON_FINITE)
    feed(T0 + 2 * MS, (names, q, [], eff), SkipReason.NO_VELOCITY)
    feed(T0 + 2 * MS, (names, [], qd, eff), SkipReason.NO_POSITION)
    feed(T0 + 2 * MS, (names, q[:3], qd, eff), SkipReason.LENGTH_MISMATCH)
    feed(T0 + 2 * MS, (names, q, qd, eff + [1.0]), SkipReason.LENGTH_MISMATCH)
    feed(T0 + 2 * MS, (['joint1', 'joint2', 'jointX', 'joint4'], q, qd, eff),
         SkipReason.UNKNOWN_JOINT)
    feed(T0 + 2 * MS, (names[:3], q[:3], qd[:3], eff[:3]), SkipReason.MISSING_JOINT)
    feed(T0 + 2 * MS, (['joint1', 'joint1', 'joint3', 'joint4'], q, qd, eff),
         SkipReason.DUPLICATE_JOINT)
    feed(T0 + 2 * MS, message(2, order=(3, 1, 0, 2)), None, 2)  # reordered: mapped by name
    feed(T0 + 2 * MS, message(2), SkipReason.STAMP_REPEATED)
    feed(T0 + 2 * MS - 1, message(2), SkipReason.STAMP_BACKWARDS)
    feed(T0 + 3 * MS, message(3, order=(1, 0, 3, 2)), None, 3)
    feed(T0 + 4 * MS, bad(4, 2, NAN), SkipReason.NON_FINITE)
    feed(T0 + 5 * MS, message(5), None, 5)  # two intervals after 3: qdd is still exact
    feed(T0 + 5 * MS + 51 * MS, message(56), SkipReason.GAP)  # differentiator restarts here
    feed(T0 + 57 * MS, message(57), None, 57)
    for k in range(58, 70):
        feed(T0 + k * MS, message(k, order=(k % 4, (k + 1) % 4, (k + 2) % 4, (k + 3) % 4)),
             None, k)

    counts = ident.counts
    expected_skips = {SkipReason.NON_FINITE: 5, SkipReason.NO_VELOCITY: 1,
                      SkipReason.NO_POSITION: 1,
                      SkipReason.LENGTH_MISMATCH: 2, SkipReason.UNKNOWN_JOINT: 1,
                      SkipReason.MISSING_JOINT: 1, SkipReason.DUPLICATE_JOINT: 1,
                      SkipReason.STAMP_REPEATED: 1, SkipReason.STAMP_BACKWARDS: 1,
                      SkipReason.GAP: 1, SkipReason.WARMING_UP: 1}
    assert counts.skipped == {**dict.fromkeys(SkipReason, 0), **expected_skips}
    assert counts.predicted == counts.learnt == len(good)
    assert counts.processed == counts.predicted + sum(counts.skipped.values())

    # The model learnt from exactly the good samples, in order, in joint order, all finite.
    fits = model.fits()
    for (x, y), k in zip(fits, good, strict=True):
        assert x.shape == (1, 3 * N) and y.shape == (1, N)
        assert np.isfinite(x).all() and np.isfinite(y).all()
        np.testing.assert_allclose(x[0], expected_x(k), rtol=1e-9)
        np.testing.assert_array_equal(y[0], state(k)[2])
    assert ident.error_stats().count == len(good)


def test_predictions_are_a_priori() -> None:
    model = RecordingModel(rate=0.005)
    ident = make(model)
    results = [one(ident.process(T0 + k * MS, *message(k))) for k in range(30)]
    kinds = [kind for kind, _, _ in model.events]
    assert kinds == ['predict', 'fit'] * 29  # each prediction before the step learning it
    for k, result in enumerate(results[1:], start=1):  # results[0] is warming up
        (_, x_pred, weights), (_, x_fit, _) = model.events[2 * k - 2:2 * k]
        np.testing.assert_array_equal(x_pred, x_fit[0])
        assert result.effort is not None
        # The prediction is the one made with the weights from before learning this sample.
        np.testing.assert_allclose(result.effort, x_pred @ weights.T, rtol=1e-13)
    # Learning did change the weights from one prediction to the next: an a-posteriori
    # prediction would have differed, so the check above has teeth.
    weights_seen = [w for kind, _, w in model.events if kind == 'predict']
    assert all(not np.allclose(a, b) for a, b in pairwise(weights_seen))
    errors = [(r.effort - state(k)[2]) ** 2 for k, r in enumerate(results) if r.effort is not None]
    stats = ident.error_stats()
    np.testing.assert_allclose(stats.mse, np.mean(errors, axis=0), rtol=1e-12)


def test_rejected_velocity_does_not_poison_later_accelerations() -> None:
    clean, hostile = RecordingModel(rate=1e-5), RecordingModel(rate=1e-5)
    for method in ('lowpass', 'polynomial'):
        a = make(clean, differentiator=Differentiator(method, window=4))
        b = make(hostile, differentiator=Differentiator(method, window=4))
        for k in range(40):
            msg = message(k)
            msg[2][1] += 1e-4 * k * k  # a curved velocity: the filters' state matters
            a.process(T0 + k * MS, *msg)
            if k % 7 == 3:
                poisoned = message(k)
                poisoned[2][1] = NAN  # at the stamp of a good sample, which follows it
                assert one(b.process(T0 + k * MS, *poisoned)).reason is \
                    SkipReason.NON_FINITE
            b.process(T0 + k * MS, *msg)
    for (xa, ya), (xb, yb) in zip(clean.fits(), hostile.fits(), strict=True):
        np.testing.assert_array_equal(xa, xb)
        np.testing.assert_array_equal(ya, yb)


def test_reordered_messages_train_the_same_as_ordered_ones() -> None:
    ordered, shuffled = RecordingModel(), RecordingModel()
    a, b = make(ordered), make(shuffled)
    rng = np.random.default_rng(3)
    for k in range(20):
        ra = one(a.process(T0 + k * MS, *message(k)))
        rb = one(b.process(T0 + k * MS, *message(k, order=rng.permutation(N).tolist())))
        assert ra.reason is rb.reason
        if ra.effort is not None:
            np.testing.assert_array_equal(ra.effort, rb.effort)
    for (xa, ya), (xb, yb) in zip(ordered.fits(), shuffled.fits(), strict=True):
        np.testing.assert_array_equal(xa, xb)
        np.testing.assert_array_equal(ya, yb)


def test_joint_order_from_the_first_valid_message() -> None:
    model = RecordingModel(n_outputs=3)
    ident = make(model, joint_names=None)
    assert ident.joint_names is None and ident.n_joints == 3
    assert one(ident.process(T0, ['a', 'b'], [1, 2], [1, 2], [1, 2])).reason is \
        SkipReason.JOINT_COUNT
    assert one(ident.process(T0, ['c', 'a', 'b'], [3, 1, 2], [0, 0, 0],
                             [30, 10, 20])).reason is SkipReason.WARMING_UP
    assert ident.joint_names == ('c', 'a', 'b')
    result = one(ident.process(T0 + MS, ['a', 'b', 'c'], [1, 2, 3], [0.001, 0.002, 0.003],
                               [10, 20, 30]))
    assert result.effort is not None
    x, y = model.fits()[0]
    np.testing.assert_allclose(x[0], [3, 1, 2, 0.003, 0.001, 0.002, 3, 1, 2])
    np.testing.assert_array_equal(y[0], [30, 10, 20])


def test_prediction_only_mode() -> None:
    model = RecordingModel()
    ident = make(model, learn=False)
    for k in range(10):
        names, q, qd, effort = message(k)
        ident.process(T0 + k * MS, names, q, qd, effort if k % 2 else [])
    assert ident.counts.predicted == 9 and ident.counts.learnt == 0
    assert model.fits() == []
    assert ident.error_stats().count == 5  # only samples that carried an effort
    assert ident.paper_error().count == 5


def test_gap_restarts_the_differentiator_and_reset_restarts_the_stream() -> None:
    model = RecordingModel()
    ident = make(model, differentiator=Differentiator('polynomial', window=3, degree=1))
    reasons = [one(ident.process(T0 + k * MS, *message(k))).reason for k in range(5)]
    assert reasons == [SkipReason.WARMING_UP] * 2 + [None] * 3
    reasons = [one(ident.process(T0 + k * MS, *message(k))).reason for k in range(100, 104)]
    assert reasons == [SkipReason.GAP, SkipReason.WARMING_UP, None, None]
    ident.reset()
    assert ident.error_stats().count == 0
    reasons = [one(ident.process(T0 + k * MS, *message(k))).reason
               for k in range(3)]  # time went back
    assert reasons == [SkipReason.WARMING_UP] * 2 + [None]
    assert ident.counts.processed == 12 and ident.counts.learnt == 6


@pytest.mark.parametrize('n_outputs, kwargs', [
    (4, {'joint_names': NAMES[:3]}),
    (4, {'mse_window': 99}),
    (0, {}),
])
def test_bad_configuration_is_refused(n_outputs: int, kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        make(RecordingModel(n_outputs=n_outputs), **kwargs)


def test_model_sizes_must_be_3n_to_n() -> None:
    model = RecordingModel()
    model.n_inputs = 8
    with pytest.raises(ValueError, match='3n inputs'):
        make(model)


def test_zero_phase_predictions_are_a_priori_and_stamped_with_their_sample() -> None:
    model = RecordingModel(rate=0.005)
    ident = make(model, differentiator=None)  # the default: centred, 10 samples late
    assert ident.lag == 10
    out: list[tuple[int, StepResult]] = []
    for k in range(40):
        results = ident.process(T0 + k * MS, *message(k))
        out += [(k, r) for r in results]
    out += [(40, r) for r in ident.finish()]
    # every sample predicted once, in order, each once the 10 after it had arrived
    assert [r.stamp_ns for _, r in out] == [T0 + k * MS for k in range(40)]
    assert all(arrived >= min((r.stamp_ns - T0) // MS + 10, 20) for arrived, r in out)
    kinds = [kind for kind, _, _ in model.events]
    assert kinds == ['predict', 'fit'] * 40
    for j, (_, result) in enumerate(out):
        (_, x_pred, weights), (_, x_fit, _) = model.events[2 * j:2 * j + 2]
        np.testing.assert_array_equal(x_pred, x_fit[0])
        np.testing.assert_allclose(x_fit[0], expected_x(j), rtol=1e-9)  # exact q''
        assert result.effort is not None
        np.testing.assert_allclose(result.effort, x_pred @ weights.T, rtol=1e-13)


def test_sporadic_bad_messages_do_not_stall_the_estimate() -> None:
    """6 bad messages in every 10 (NaN, no velocity, wrong lengths, an unknown joint, a stamp
    0.5 s back, inf) between 4 good ones: a refused sample is a missing one, so once the
    window has filled every good sample is predicted."""
    identifier = OnlineIdentifier(RecordingModel(), joint_names=NAMES, learn=False)
    good = predicted = 0
    for k in range(1000):
        stamp = T0 + k * MS
        q, qd, e = state(k)
        kind = k % 10
        if kind < 4:
            good += 1
            results = identifier.process(stamp, NAMES, q, qd, e)
        else:
            bad = {4: (NAMES, [NAN, *q[1:]], qd, e), 5: (NAMES, q, [], e),
                   6: (NAMES, q[:3], qd, e), 7: (('joint1', 'joint2', 'joint3', 'joint9'),
                                                 q, qd, e),
                   8: (NAMES, q, qd, e), 9: (NAMES, q, qd, [*e[:3], INF])}[kind]
            results = identifier.process(stamp - 500 * MS if kind == 8 else stamp, *bad)
            assert results[0].effort is None and results[0].reason is not None
            assert results[0].reason is not SkipReason.GAP
        predicted += sum(result.effort is not None for result in results)
    predicted += len(identifier.finish())
    assert good == 400
    assert predicted == good
    assert identifier.counts.skipped[SkipReason.WARMING_UP] == 0
    assert identifier.counts.skipped[SkipReason.STAMP_BACKWARDS] == 100


def test_single_missing_samples_keep_the_estimate() -> None:
    """Samples lost one at a time (every 50th) are gaps of 2 ms, not clock gaps: the q''
    estimate goes on and every sample that came is predicted."""
    identifier = OnlineIdentifier(RecordingModel(), joint_names=NAMES, learn=False)
    came = predicted = 0
    for k in range(2000):
        if k % 50 == 49:
            continue
        came += 1
        results = identifier.process(T0 + k * MS, NAMES, *state(k))
        predicted += sum(result.effort is not None for result in results)
    predicted += len(identifier.finish())
    assert predicted == came
    assert identifier.counts.skipped[SkipReason.WARMING_UP] == 0
    assert identifier.counts.skipped[SkipReason.GAP] == 0
