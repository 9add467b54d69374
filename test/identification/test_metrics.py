"""MSE and NMSE as documented: checked against hand computations and ErrorWindow."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.identification.error_window import recent_errors
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.identification import ErrorWindow


def test_effort_errors_match_a_hand_computation() -> None:
    # joint 1: efforts 1, 2, 3, 4 (mean 2.5, variance 1.25), errors 1, 0, -1, 0
    # joint 2: efforts 10, 10, 20, 20 (variance 25), errors 0, 0, 0, 2
    Y = np.array([[1.0, 10.0], [2.0, 10.0], [3.0, 20.0], [4.0, 20.0]])
    Y_hat = np.array([[0.0, 10.0], [2.0, 10.0], [4.0, 20.0], [4.0, 18.0]])
    stats = effort_errors(Y, Y_hat)
    np.testing.assert_allclose(stats.mse, [0.5, 1.0])
    np.testing.assert_allclose(stats.nmse, [0.5 / 1.25, 1.0 / 25.0])
    assert stats.mse_total == pytest.approx(0.75)
    assert stats.nmse_total == pytest.approx((0.4 + 0.04) / 2)
    assert stats.smse == pytest.approx((0.5 + 1.0) / (1.25 + 25.0))
    assert stats.count == 4


def test_smse_is_one_minus_the_variance_weighted_r2() -> None:
    from sklearn.metrics import r2_score

    rng = np.random.default_rng(1)
    Y = rng.normal(size=(200, 3)) * [1.0, 30.0, 0.1]
    Y_hat = Y + rng.normal(size=Y.shape) * [0.3, 3.0, 0.05]
    r2 = r2_score(Y, Y_hat, multioutput='variance_weighted')
    assert effort_errors(Y, Y_hat).smse == pytest.approx(1.0 - r2, rel=1e-12)


def test_nmse_is_free_of_units() -> None:
    rng = np.random.default_rng(0)
    Y = rng.normal(size=(50, 3))
    Y_hat = Y + 0.1 * rng.normal(size=Y.shape)
    scale = np.array([1.0, 100.0, 1e-3])
    np.testing.assert_allclose(effort_errors(Y * scale, Y_hat * scale).nmse,
                               effort_errors(Y, Y_hat).nmse)


def test_predicting_the_mean_gives_nmse_one() -> None:
    Y = np.random.default_rng(1).normal(size=(200, 4))
    stats = effort_errors(Y, np.broadcast_to(Y.mean(axis=0), Y.shape))
    np.testing.assert_allclose(stats.nmse, 1.0)


def test_constant_effort_leaves_nmse_undefined_for_that_joint_only() -> None:
    Y = np.array([[1.0, 5.0], [2.0, 5.0], [3.0, 5.0]])
    stats = effort_errors(Y, Y + 1.0)
    assert stats.nmse[0] == pytest.approx(1.5) and np.isnan(stats.nmse[1])
    assert stats.nmse_total == pytest.approx(1.5)
    assert stats.smse == pytest.approx(1.5)  # the constant joint counts in neither sum


def test_recent_errors_are_the_error_windows_over_the_last_k() -> None:
    rng = np.random.default_rng(2)
    Y = rng.normal(size=(1000, 4)) * [30.0, 10.0, 50.0, 1.0]
    Y_hat = Y + rng.normal(size=Y.shape)
    recent = recent_errors(Y, Y_hat, 100)
    direct = effort_errors(Y[-100:], Y_hat[-100:])
    window = ErrorWindow(4, 1000)
    for y, y_hat in zip(Y, Y_hat):
        window.update(y, y_hat)
    node = window.recent(100)
    assert recent.count == direct.count == node.count == 100
    for stats in (direct, node):
        np.testing.assert_allclose(recent.mse, stats.mse, rtol=1e-12)
        np.testing.assert_allclose(recent.nmse, stats.nmse, rtol=1e-9)


def test_shape_mismatch_is_an_error() -> None:
    with pytest.raises(ValueError, match='same shape'):
        effort_errors(np.zeros((3, 2)), np.zeros((3, 3)))
