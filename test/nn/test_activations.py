"""Activations against their formulas, central differences, and extreme inputs."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from scara_ident_ros.nn import ACTIVATIONS, DEFAULT_CONSTANTS, DERIVATIVES, FeedForwardNet
from scara_ident_ros.nn.activations import logistic, logistic_derivative
from scara_ident_ros.nn.network import forward_scaled


def naive_sigmoid(z: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-z))


def test_tables_have_the_three_networks() -> None:
    assert set(ACTIVATIONS) == set(DERIVATIVES) == set(DEFAULT_CONSTANTS) == {
        'sigmoid', 'slog', 'mslog'}
    assert DEFAULT_CONSTANTS['mslog'] == (2.5, 5.0, 5.0)
    assert DEFAULT_CONSTANTS['sigmoid'] == DEFAULT_CONSTANTS['slog'] == (1.0, 1.0, 0.0)


def test_formulas_of_the_paper() -> None:
    z = np.linspace(-8.0, 8.0, 101)
    s = naive_sigmoid
    slog = s(z + 2) - s(z + 3) - s(z - 3) + s(z - 1)  # eq. 1
    np.testing.assert_allclose(ACTIVATIONS['sigmoid'](z), s(z), rtol=1e-14)
    np.testing.assert_allclose(ACTIVATIONS['slog'](z), slog, atol=1e-15)
    np.testing.assert_allclose(ACTIVATIONS['mslog'](z), 2.5 * slog, atol=1e-14)  # eq. 2
    np.testing.assert_allclose(ACTIVATIONS['mslog'](z, 1.5), 1.5 * slog, atol=1e-14)
    ds = s(z) * (1 - s(z))
    d_slog = (s(z + 2) * (1 - s(z + 2)) - s(z + 3) * (1 - s(z + 3))
              - s(z - 3) * (1 - s(z - 3)) + s(z - 1) * (1 - s(z - 1)))  # eq. 3
    np.testing.assert_allclose(DERIVATIVES['sigmoid'](z), ds, rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(DERIVATIVES['mslog'](z), 2.5 * d_slog, atol=1e-14)


@pytest.mark.parametrize('k', [1.0, 2.5])
def test_derivative_matches_central_differences(name: str, k: float) -> None:
    z = np.linspace(-12.0, 12.0, 241)
    step = 1e-5
    f = ACTIVATIONS[name]
    numeric = (f(z + step, k) - f(z - step, k)) / (2 * step)
    np.testing.assert_allclose(DERIVATIVES[name](z, k), numeric, rtol=1e-7, atol=1e-10)


def test_no_overflow_and_right_limits_for_huge_inputs(name: str) -> None:
    z = np.array([-1e308, -1e5, -800.0, -40.0, 40.0, 800.0, 1e5, 1e308])
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        f = ACTIVATIONS[name](z)
        d = DERIVATIVES[name](z)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(d))
    assert np.all(d[[0, 1, 2, -3, -2, -1]] == 0.0)
    expected_right = 1.0 if name == 'sigmoid' else 0.0  # SLOG: +1 − 1 − 1 + 1
    np.testing.assert_allclose(f[-3:], expected_right, atol=1e-300)
    np.testing.assert_allclose(f[:3], 0.0, atol=1e-300)


def test_logistic_keeps_relative_accuracy_in_the_tail() -> None:
    z = np.array([-700.0, -50.0, -20.0])
    np.testing.assert_allclose(logistic(z), np.exp(z) / (1 + np.exp(z)), rtol=1e-14)
    np.testing.assert_allclose(logistic_derivative(z), np.exp(z) / (1 + np.exp(z)) ** 2,
                               rtol=1e-14)


def test_network_hidden_layer_is_the_table_activation(name: str) -> None:
    """The network's fused tanh forms agree with the reference functions."""
    net = FeedForwardNet(5, 7, 2, name, k=1.7, a=0.8, b=0.3, weight_scale=6.0, seed=3)
    xs = np.random.default_rng(0).uniform(-1, 1, (30, 5))
    layers = forward_scaled(net, xs, derivative=True)
    k, a, b = net.constants
    Vt, _ = net.unpack(net.get_theta())
    z = (xs @ Vt[:5] + Vt[5] - b) / a
    np.testing.assert_allclose(layers.h, ACTIVATIONS[name](z, k), atol=1e-14)
    assert layers.g is not None
    np.testing.assert_allclose(layers.g, DERIVATIVES[name](z, k) / a, atol=1e-14)
