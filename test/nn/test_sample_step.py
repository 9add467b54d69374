"""The per-sample path: the online step is SGD with momentum, in physical units."""
from __future__ import annotations

import pickle

import numpy as np
import pytest

from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.batch import loss_gradient


def scaled_net(name: str = 'mslog', **options: float) -> FeedForwardNet:
    net = FeedForwardNet(12, 40, 4, name, **options)  # type: ignore[arg-type]
    net.set_scaling(-np.ones(12), np.ones(12), -np.ones(4), np.ones(4))
    return net


def test_online_step_is_sgd_with_momentum(name: str) -> None:
    net = scaled_net(name, learning_rate=0.01, momentum=0.5, seed=4)
    rng = np.random.default_rng(4)
    x, y = rng.uniform(-1, 1, (2, 12)), rng.uniform(-1, 1, (2, 4))
    theta0 = net.get_theta()
    _, g0 = loss_gradient(net, x[:1], y[:1])
    prior = net.predict(x[0])
    error = net.partial_fit(x[0], y[0])
    np.testing.assert_allclose(error, y[0] - prior, rtol=1e-12, atol=1e-14)
    theta1 = net.get_theta()
    np.testing.assert_allclose(theta1, theta0 - 0.01 * g0, rtol=1e-11, atol=1e-15)
    _, g1 = loss_gradient(net, x[1:], y[1:])
    net.partial_fit(x[1], y[1])
    expected = theta1 + 0.5 * (theta1 - theta0) - 0.01 * g1
    np.testing.assert_allclose(net.get_theta(), expected, rtol=1e-11, atol=1e-15)


def test_online_step_learns_in_physical_units() -> None:
    net = FeedForwardNet(2, 3, 1, learning_rate=0.1, momentum=0.0)
    net.set_scaling([0, 0], [10, 10], [0], [100])
    theta0 = net.get_theta()
    x, y = np.array([2.0, 7.0]), np.array([30.0])
    xs, ys = np.array([[-0.6, 0.4]]), np.array([[-0.4]])
    _, grad = loss_gradient(net, xs, ys)
    net.partial_fit(x, y)
    np.testing.assert_allclose(net.get_theta(), theta0 - 0.1 * grad, rtol=1e-12)


def test_partial_fit_shapes() -> None:
    net = scaled_net()
    rng = np.random.default_rng(5)
    x, y = rng.uniform(-1, 1, (6, 12)), rng.uniform(-1, 1, (6, 4))
    assert net.partial_fit(x[0], y[0]).shape == (4,)
    assert net.partial_fit(x, y).shape == (6, 4)
    assert net.partial_fit(x[:1], y[:1]).shape == (1, 4)
    with pytest.raises(ValueError, match='shape'):
        net.partial_fit(x, y[:5])
    with pytest.raises(ValueError, match='shape'):
        net.partial_fit(x[0], y[0, :3])


def test_partial_fit_batch_equals_sample_by_sample() -> None:
    rng = np.random.default_rng(6)
    x, y = rng.uniform(-1, 1, (10, 12)), rng.uniform(-1, 1, (10, 4))
    a, b = scaled_net(), scaled_net()
    errors = a.partial_fit(x, y)
    for i in range(10):
        np.testing.assert_array_equal(errors[i], b.partial_fit(x[i], y[i]))
    np.testing.assert_array_equal(a.get_theta(), b.get_theta())


def test_partial_fit_needs_scaling() -> None:
    net = FeedForwardNet(12, 40, 4)
    with pytest.raises(RuntimeError, match='set_scaling'):
        net.partial_fit(np.zeros(12), np.zeros(4))


@pytest.mark.filterwarnings('ignore:invalid value:RuntimeWarning')
def test_non_finite_sample_is_refused_and_changes_nothing() -> None:
    net = scaled_net()
    net.partial_fit(np.full(12, 0.1), np.full(4, 0.2))  # some momentum
    theta, velocity = net.get_theta(), net._velocity.copy()
    for x, y in ((np.full(12, np.nan), np.zeros(4)), (np.zeros(12), np.array([0, np.inf, 0, 0])),
                 (np.full(12, np.inf), np.zeros(4))):
        with pytest.raises(ValueError, match='non-finite'):
            net.partial_fit(x, y)
        np.testing.assert_array_equal(net.get_theta(), theta)
        np.testing.assert_array_equal(net._velocity, velocity)


def test_learning_rate_and_momentum_can_change_online() -> None:
    net = scaled_net(momentum=0.0)
    net.learning_rate = 0.0125
    theta0 = net.get_theta()
    x, y = np.full(12, 0.3), np.full(4, -0.2)
    _, grad = loss_gradient(net, x[None], y[None])
    net.partial_fit(x, y)
    np.testing.assert_allclose(net.get_theta(), theta0 - 0.0125 * grad, rtol=1e-11)
    with pytest.raises(ValueError):
        net.learning_rate = -1.0


def test_option_changes_and_pickling_keep_partial_fit_tied_to_the_scaling() -> None:
    """The per-sample path is rebuilt after an option change and on unpickling: without a
    scaling partial_fit refuses, with one it steps at the network's current options."""
    net = FeedForwardNet(12, 40, 4, momentum=0.0)
    net.learning_rate = 0.0125
    for copy in (net, pickle.loads(pickle.dumps(net))):
        with pytest.raises(RuntimeError, match='scaling'):
            copy.partial_fit(np.zeros(12), np.zeros(4))
    net.set_scaling(-np.ones(12), np.ones(12), -np.ones(4), np.ones(4))
    copy = pickle.loads(pickle.dumps(net))
    x, y = np.full(12, 0.3), np.full(4, -0.2)
    _, grad = loss_gradient(copy, x[None], y[None])
    copy.partial_fit(x, y)
    np.testing.assert_allclose(copy.get_theta(), net.get_theta() - 0.0125 * grad, rtol=1e-11)


def test_partial_fit_reduces_error_on_a_simple_function(name: str) -> None:
    rng = np.random.default_rng(7)
    x = rng.uniform(-1, 1, (3000, 2))
    y = np.stack([np.sin(2 * x[:, 0]) * x[:, 1], x[:, 0] ** 2 - x[:, 1]], axis=1)
    net = FeedForwardNet(2, 10, 2, name, learning_rate=0.02, momentum=0.5)
    net.set_scaling([-1, -1], [1, 1], [-1, -1.5], [1, 1.5])
    before = np.mean((net.predict(x) - y) ** 2)
    for _ in range(3):
        net.partial_fit(x, y)
    after = np.mean((net.predict(x) - y) ** 2)
    assert after < 0.1 * before, (before, after)


def test_an_unpickled_network_predicts_one_sample_with_its_new_weights() -> None:
    """The per-sample path reads the weights through views of θ; unpickled (as a learner
    process receives it), set_theta must still reach it."""
    copy = pickle.loads(pickle.dumps(scaled_net(seed=1)))
    copy.set_theta(scaled_net(seed=2).get_theta())
    x = np.random.default_rng(3).uniform(-1.0, 1.0, (5, 12))
    np.testing.assert_allclose(copy.predict(x[0]), copy.predict(x)[0], rtol=1e-12)
