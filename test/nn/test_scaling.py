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
