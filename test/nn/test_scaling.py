"""MinMaxScaling maps ranges to [-1, 1] and back."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.nn import MinMaxScaling


def test_maps_range_to_unit_interval_and_back() -> None:
    scaling = MinMaxScaling(np.array([-2.0, 0.0, 5.0]), np.array([2.0, 10.0, 5.0]))
    x = np.array([[-2.0, 0.0, 5.0], [2.0, 10.0, 5.0], [0.0, 2.5, 5.0]])
    s = scaling.transform(x)
    np.testing.assert_allclose(s, np.array([[-1, -1, 0], [1, 1, 0], [0, -0.5, 0]], float))
    np.testing.assert_allclose(scaling.inverse_transform(s), x)


def test_from_data_uses_column_extremes() -> None:
    data = np.random.default_rng(0).normal(size=(50, 4))
    s = MinMaxScaling.from_data(data).transform(data)
    np.testing.assert_allclose(s.min(axis=0), -1.0)
    np.testing.assert_allclose(s.max(axis=0), 1.0)


def test_rejects_bad_ranges() -> None:
    with pytest.raises(ValueError, match='hi < lo'):
        MinMaxScaling(np.array([1.0]), np.array([0.0]))
    with pytest.raises(ValueError, match='finite'):
        MinMaxScaling(np.array([0.0]), np.array([np.inf]))
    with pytest.raises(ValueError):
        MinMaxScaling(np.zeros(2), np.ones(3))


def test_standard_maps_mean_to_centre_and_k_deviations_to_the_ends() -> None:
    data = np.random.default_rng(1).normal([3.0, -2.0, 0.5], [0.1, 4.0, 2.0], (200, 3))
    mean, std = data.mean(axis=0), data.std(axis=0)
    for k in (1.0, 2.5):
        scaling = MinMaxScaling.standard(data, k)
        np.testing.assert_allclose(scaling.transform(mean), 0.0, atol=1e-12)
        np.testing.assert_allclose(scaling.transform(mean + k * std), 1.0)
        np.testing.assert_allclose(scaling.transform(mean - k * std), -1.0)
    z = MinMaxScaling.standard(data).transform(data)  # k = 1: the standard score
    np.testing.assert_allclose(z, (data - mean) / std)
    np.testing.assert_allclose(z.std(axis=0), 1.0)


def test_standard_centres_a_constant_column_and_checks_k() -> None:
    data = np.column_stack([np.full(10, 7.0), np.arange(10.0)])
    assert MinMaxScaling.standard(data).transform(data)[:, 0] == pytest.approx(0.0)
    with pytest.raises(ValueError, match='k must be positive'):
        MinMaxScaling.standard(data, 0.0)
    with pytest.raises(ValueError, match='n_samples'):
        MinMaxScaling.standard(np.zeros(3))
