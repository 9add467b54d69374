"""FeedForwardNet: shapes, constructor checks, seeds, prediction in physical units."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.nn import FeedForwardNet


def test_sizes_and_parameter_count() -> None:
    net = FeedForwardNet(12, 40, 4)
    assert net.n_params == 40 * 13 + 4 * 41 == 684
    assert FeedForwardNet(9, 25, 3, 'slog').n_params == 25 * 10 + 3 * 26
    Vt, Wt = net.unpack(net.theta)
    assert Vt.shape == (13, 40) and Wt.shape == (4, 41)
    assert np.shares_memory(Vt, net.theta) and np.shares_memory(Wt, net.theta)


def test_constructor_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match='activation'):
        FeedForwardNet(2, 3, 1, 'relu')
    with pytest.raises(ValueError, match='n_hidden'):
        FeedForwardNet(2, 0, 1)
    with pytest.raises(TypeError):
        FeedForwardNet(2, 3.5, 1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match='a non-zero'):
        FeedForwardNet(2, 3, 1, a=0.0)
    with pytest.raises(ValueError, match='momentum'):
        FeedForwardNet(2, 3, 1, momentum=1.0)


def test_default_constants_per_activation() -> None:
    assert FeedForwardNet(12, 40, 4).constants == (2.5, 5.0, 5.0)
    assert FeedForwardNet(12, 40, 4, 'slog').constants == (1.0, 1.0, 0.0)
    assert FeedForwardNet(12, 40, 4, 'mslog', k=3.0, b=1.0).constants == (3.0, 5.0, 1.0)


def test_seeds_are_reproducible() -> None:
    a, b = FeedForwardNet(12, 40, 4, seed=7), FeedForwardNet(12, 40, 4, seed=7)
    np.testing.assert_array_equal(a.get_theta(), b.get_theta())
    assert not np.array_equal(a.get_theta(), FeedForwardNet(12, 40, 4, seed=8).get_theta())


def test_predict_shapes_single_and_batch() -> None:
    net = FeedForwardNet(12, 40, 4)
    x = np.random.default_rng(0).uniform(-1, 1, (5, 12))
    batch = net.predict(x)
    assert batch.shape == (5, 4)
    single = net.predict(x[2])
    assert single.shape == (4,)
    np.testing.assert_allclose(single, batch[2], rtol=1e-13)
    assert net.predict(x[2].tolist()).shape == (4,)
    with pytest.raises(ValueError, match='shape'):
        net.predict(np.zeros((5, 11)))


def test_predict_uses_physical_units() -> None:
    net = FeedForwardNet(2, 3, 1)
    x = np.array([[0.3, -0.2]])
    y = net.predict(x)
    net.set_scaling([-10, -10], [10, 10], [100], [300])
    np.testing.assert_allclose(net.predict(10 * x), 200 + 100 * y)
