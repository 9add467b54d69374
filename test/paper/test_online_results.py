"""Pairing predictions with measurements by stamp, and the windowed errors."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.identification import ErrorWindow
from scara_ident_ros.paper.online_results import pair_by_stamp, rolling_errors


def test_pair_by_stamp_matches_equal_stamps_in_time_order() -> None:
    meas = np.array([30, 10, 20, 40, 20], dtype=np.int64)
    pred = np.array([40, 20, 25, 10, 40], dtype=np.int64)
    i_meas, i_pred = pair_by_stamp(meas, pred)
    np.testing.assert_array_equal(meas[i_meas], [10, 20, 40])
    np.testing.assert_array_equal(pred[i_pred], [10, 20, 40])
    np.testing.assert_array_equal(i_meas, [1, 2, 3])  # first of the repeated 20
    np.testing.assert_array_equal(i_pred, [3, 1, 0])  # first of the repeated 40


@pytest.mark.parametrize('window', [1, 7, 100])
def test_rolling_errors_equal_the_identifiers_window(window: int) -> None:
    rng = np.random.default_rng(3)
    y = rng.normal(size=(300, 3)) * [1.0, 10.0, 0.1] + [0.0, 50.0, -9.81]
    y_hat = y + rng.normal(scale=0.1, size=y.shape)
    mse, nmse = rolling_errors(y, y_hat, window)
    errors = ErrorWindow(3, window)
    for k in range(y.shape[0]):
        errors.update(y[k], y_hat[k])
        stats = errors.snapshot()
        assert mse[k] == pytest.approx(stats.mse_total, rel=1e-9)
        if window > 1 and k > 0:
            assert nmse[k] == pytest.approx(stats.nmse_total, rel=1e-6)
    if window == 1:
        assert np.all(np.isnan(nmse))


def test_rolling_errors_checks_shapes() -> None:
    with pytest.raises(ValueError, match='same shape'):
        rolling_errors(np.zeros((3, 2)), np.zeros((3, 3)), 2)
    with pytest.raises(ValueError, match='window'):
        rolling_errors(np.zeros((3, 2)), np.zeros((3, 2)), 0)
    mse, nmse = rolling_errors(np.zeros((0, 2)), np.zeros((0, 2)), 5)
    assert mse.shape == nmse.shape == (0,)
