"""Tests of the sliding-window MSE / NMSE against brute force."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from scara_ident_ros.identification import PAPER_WINDOW, ErrorStats, ErrorWindow


Floats = NDArray[np.float64]


def brute(effort: Floats, predicted: Floats) -> tuple[Floats, Floats]:
    """MSE and NMSE of (k, n) arrays, the plain way."""
    mse = np.mean((effort - predicted) ** 2, axis=0)
    with np.errstate(divide='ignore', invalid='ignore'):  # one sample: no variance yet
        return mse, mse / np.var(effort, axis=0)


def stream(count: int, n: int, seed: int = 0) -> tuple[Floats, Floats]:
    rng = np.random.default_rng(seed)
    # A large mean on one joint, as gravity puts on joint 3: the variance must not cancel.
    effort = rng.normal(0.0, 1.0, (count, n)) * [2.0, 0.5, 1e-3] + [0.0, 3.0, 5e3]
    return effort, effort + rng.normal(0.0, 0.1, (count, n)) * [1.0, 1.0, 1e-4]


def assert_matches_brute(stats: ErrorStats, effort: Floats, predicted: Floats, k: int,
                         window: int, rtol: tuple[float, float]) -> tuple[Floats, Floats]:
    """Check ``stats`` after sample k against brute force over the last ``window`` samples
    (MSE and, from the second sample on, NMSE to ``rtol``); return that MSE and NMSE."""
    lo = max(0, k + 1 - window)
    mse, nmse = brute(effort[lo:k + 1], predicted[lo:k + 1])
    assert stats.count == k + 1 - lo
    np.testing.assert_allclose(stats.mse, mse, rtol=rtol[0])
    if k > 0:
        np.testing.assert_allclose(stats.nmse, nmse, rtol=rtol[1])
    return mse, nmse


def test_running_statistics_match_brute_force() -> None:
    window = 37
    effort, predicted = stream(500, 3)
    errors = ErrorWindow(3, window)
    for k in range(len(effort)):
        errors.update(effort[k], predicted[k])
        stats = errors.snapshot()
        mse, nmse = assert_matches_brute(stats, effort, predicted, k, window, (1e-9, 1e-6))
        if k > 0:
            assert stats.nmse_total == pytest.approx(float(np.mean(nmse)), rel=1e-6)
        assert stats.mse_total == pytest.approx(float(np.mean(mse)), rel=1e-9)


def test_no_drift_after_errors_shrink_by_orders_of_magnitude() -> None:
    window = 50
    rng = np.random.default_rng(1)
    errors = ErrorWindow(2, window)
    effort = rng.normal(size=(1000, 2))
    scale = np.where(np.arange(1000) < 300, 1e4, 1e-4)[:, np.newaxis]  # learning converged
    predicted = effort + scale * rng.normal(size=(1000, 2))
    for y, p in zip(effort, predicted, strict=True):
        errors.update(y, p)
    mse, nmse = brute(effort[-window:], predicted[-window:])
    stats = errors.snapshot()
    np.testing.assert_allclose(stats.mse, mse, rtol=1e-9)
    np.testing.assert_allclose(stats.nmse, nmse, rtol=1e-9)


def test_recent_is_the_exact_figure_over_the_last_k() -> None:
    effort, predicted = stream(730, 3, seed=2)
    errors = ErrorWindow(3, 250)
    for k in range(len(effort)):
        errors.update(effort[k], predicted[k])
        if k in (0, 57, 99, 100, 249, 250, 611, 729):
            assert_matches_brute(errors.recent(), effort, predicted, k, PAPER_WINDOW,
                                 (1e-12, 1e-9))
    with pytest.raises(ValueError, match='k must be'):
        errors.recent(251)
    with pytest.raises(ValueError, match='k must be'):
        errors.recent(0)


def test_empty_and_constant_windows() -> None:
    errors = ErrorWindow(2, 10)
    stats = errors.snapshot()
    assert stats.count == 0 and np.isnan(stats.mse).all() and np.isnan(stats.nmse).all()
    assert math.isnan(stats.mse_total) and math.isnan(stats.nmse_total)
    for k in range(15):
        errors.update([5.0, float(k)], [4.0, float(k) + 0.5])  # joint 1's effort is constant
    stats = errors.snapshot()
    assert stats.count == 10
    np.testing.assert_allclose(stats.mse, [1.0, 0.25])
    assert math.isnan(stats.nmse[0])
    assert stats.nmse[1] == pytest.approx(0.25 / np.var(np.arange(5.0, 15.0)))
    assert stats.nmse_total == pytest.approx(stats.nmse[1])  # the joints where it is defined
    assert isinstance(errors.recent(3), ErrorStats)


def test_reset_empties_the_window() -> None:
    errors = ErrorWindow(1, 4)
    for k in range(6):
        errors.update([float(k)], [0.0])
    errors.reset()
    assert errors.count == 0
    errors.update([2.0], [1.0])
    errors.update([4.0], [4.0])
    stats = errors.snapshot()
    assert stats.count == 2
    np.testing.assert_allclose(stats.mse, [0.5])
    np.testing.assert_allclose(stats.nmse, [0.5])


@pytest.mark.parametrize('n_joints, window', [(0, 10), (2, 0)])
def test_bad_sizes_are_refused(n_joints: int, window: int) -> None:
    with pytest.raises(ValueError):
        ErrorWindow(n_joints, window)
