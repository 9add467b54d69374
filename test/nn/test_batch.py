"""Batch computations: the gradient and the Jacobian against central differences."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.batch import jacobian, loss_gradient, mse_scaled
from scara_ident_ros.nn.network import forward_scaled


def central_differences(f: Callable[[np.ndarray], Any], theta: np.ndarray,
                        step: float = 1e-6) -> np.ndarray:
    """d f / d theta_i by central differences, of shape (theta.size, *f's shape)."""
    rows = []
    for i in range(theta.size):
        plus, minus = theta.copy(), theta.copy()
        plus[i] += step
        minus[i] -= step
        rows.append((np.asarray(f(plus)) - np.asarray(f(minus))) / (2 * step))
    return np.array(rows)


def test_loss_gradient_matches_central_differences(name: str) -> None:
    net = FeedForwardNet(12, 40, 4, name, seed=1)
    rng = np.random.default_rng(1)
    xs, ys = rng.uniform(-1, 1, (20, 12)), rng.uniform(-1, 1, (20, 4))
    theta = net.get_theta()
    sse, grad = loss_gradient(net, xs, ys)
    assert sse == pytest.approx(mse_scaled(net, xs, ys) * ys.size, rel=1e-12)

    def loss(t: np.ndarray) -> float:
        return mse_scaled(net, xs, ys, t) * ys.size / (2 * len(xs))

    np.testing.assert_allclose(grad, central_differences(loss, theta), rtol=1e-5, atol=1e-9)


def test_jacobian_matches_central_differences(name: str) -> None:
    net = FeedForwardNet(4, 6, 3, name, seed=2)
    x = np.random.default_rng(2).uniform(-1, 1, (5, 4))
    jac = jacobian(net, x)
    assert jac.shape == (5 * 3, net.n_params)
    numeric = central_differences(lambda t: forward_scaled(net, x, t).y.ravel(),
                                  net.get_theta())
    np.testing.assert_allclose(jac, numeric.T, rtol=1e-6, atol=1e-9)
