"""Offline training: Levenberg–Marquardt and gradient descent, stop rules, history."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.nn import FeedForwardNet, FitHistory, fit
from scara_ident_ros.nn.batch import loss_gradient, mse_scaled
from scara_ident_ros.nn.network import forward_scaled
from scara_ident_ros.nn.gradient_descent import GradientDescent
from scara_ident_ros.nn.levenberg_marquardt import LevenbergMarquardt
from scara_ident_ros.nn.training import run_training

Data = tuple[np.ndarray, np.ndarray]


def test_lm_reaches_a_tight_goal_fast_and_beats_gd(name: str, smooth_data: Data) -> None:
    x, y = smooth_data
    lm = fit(FeedForwardNet(12, 20, 4, name), x, y, iterations=100, goal=1e-4)
    assert lm.stop_reason == 'goal', lm.mse[-1]
    assert lm.mse[-1] <= 1e-4
    gd = fit(FeedForwardNet(12, 20, 4, name), x, y, algorithm='gd', iterations=100, goal=1e-4)
    assert gd.stop_reason == 'iterations'
    assert gd.mse[-1] > 10 * lm.mse[-1]
    assert gd.mse[-1] < gd.mse[0]  # gradient descent does learn, slowly


def test_history_records_every_iteration(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4)
    history = fit(net, x, y, iterations=5)
    assert isinstance(history, FitHistory)
    assert history.algorithm == 'lm' and history.stop_reason == 'iterations'
    assert history.iterations == history.best_iteration == 5
    assert len(history.mse) == 6 and len(history.time) == 5 and len(history.mu) == 5
    assert history.val_mse is None
    assert all(b < a for a, b in zip(history.mse, history.mse[1:]))  # LM steps only downhill
    assert all(t > 0 for t in history.time)
    xs, ys = net.x_scaling.transform(x), net.y_scaling.transform(y)
    assert history.final_mse == pytest.approx(np.mean((forward_scaled(net, xs).y - ys) ** 2))


def test_fit_sets_scaling_from_data_once(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4)
    assert not net.scaling_set
    fit(net, x, y, iterations=1)
    assert net.scaling_set
    np.testing.assert_array_equal(net.y_scaling.lo, y.min(axis=0))
    np.testing.assert_array_equal(net.x_scaling.hi, x.max(axis=0))
    fit(net, 2 * x, y, iterations=1)  # keeps the scaling it has
    np.testing.assert_array_equal(net.x_scaling.hi, x.max(axis=0))


def test_fit_keeps_scaling_that_was_set(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4)
    net.set_scaling(-2 * np.ones(12), 2 * np.ones(12), -20 * np.ones(4), 20 * np.ones(4))
    fit(net, x, y, iterations=1)
    np.testing.assert_array_equal(net.x_scaling.lo, -2.0)


def test_goal_already_met_does_nothing(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4)
    theta = net.get_theta()
    history = fit(net, x, y, goal=1e3)
    assert history.stop_reason == 'goal' and history.iterations == 0
    np.testing.assert_array_equal(net.get_theta(), theta)


def test_validation_stops_and_restores_best_weights() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (40, 3))
    y = np.sin(3 * x[:, :1]) + 0.3 * rng.normal(size=(40, 1))  # noisy: LM overfits
    xv = rng.uniform(-1, 1, (200, 3))
    yv = np.sin(3 * xv[:, :1])
    net = FeedForwardNet(3, 30, 1, 'sigmoid')
    history = fit(net, x, y, iterations=300, validation=(xv, yv), max_fail=4)
    assert history.stop_reason == 'validation'
    assert history.val_mse is not None and len(history.val_mse) == history.iterations + 1
    best = int(np.argmin(history.val_mse))
    assert history.best_iteration == best == history.iterations - 4
    xvs, yvs = net.x_scaling.transform(xv), net.y_scaling.transform(yv)
    assert mse_scaled(net, xvs, yvs) == pytest.approx(history.val_mse[best], rel=1e-12)
    assert history.final_mse == history.mse[best]


def test_callback_can_stop_training(smooth_data: Data) -> None:
    x, y = smooth_data
    seen: list[int] = []

    def callback(history: FitHistory) -> bool:
        seen.append(history.iterations)
        return history.iterations == 3

    history = fit(FeedForwardNet(12, 8, 4), x, y, algorithm='gd', callback=callback)
    assert seen == [1, 2, 3] and history.stop_reason == 'callback'


def test_gd_divergence_stops_with_finite_weights(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4, 'sigmoid', learning_rate=1e6, momentum=0.0)
    history = fit(net, x, y, algorithm='gd', iterations=50)
    assert history.stop_reason in ('diverged', 'iterations')
    assert np.all(np.isfinite(net.get_theta()))


def test_lm_stops_when_mu_exceeds_its_maximum(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4)
    fit(net, x, y, iterations=0)  # sets the scaling
    xs, ys = net.x_scaling.transform(x), net.y_scaling.transform(y)
    step = LevenbergMarquardt(net, xs, ys, mu=1e3, mu_max=1e3, mu_increase=1e9)
    history = run_training(net, 'lm', step, iterations=1000, goal=0.0, validation_mse=None,
                           max_fail=6, callback=None)
    assert history.stop_reason == 'mu_max'
    assert history.iterations < 1000


def test_gd_step_is_batch_gradient_descent_with_momentum(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4, learning_rate=0.1, momentum=0.5)
    fit(net, x, y, iterations=0)
    xs, ys = net.x_scaling.transform(x), net.y_scaling.transform(y)
    theta0 = net.get_theta()
    _, g0 = loss_gradient(net, xs, ys)
    step = GradientDescent(net, xs, ys)
    step.start(FitHistory('gd'))
    step.step()
    theta1 = net.get_theta()
    np.testing.assert_allclose(theta1, theta0 - 0.1 * g0, rtol=1e-12)
    _, g1 = loss_gradient(net, xs, ys)
    step.step()
    np.testing.assert_allclose(net.get_theta(), theta1 + 0.5 * (theta1 - theta0) - 0.1 * g1,
                               rtol=1e-12)


def test_fit_rejects_bad_arguments(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4)
    with pytest.raises(ValueError, match='algorithm'):
        fit(net, x, y, algorithm='adam')
    with pytest.raises(ValueError, match='shape'):
        fit(net, x, y[:10])
    with pytest.raises(ValueError, match='finite'):
        fit(net, np.where(x > 0.99, np.nan, x), y)


def test_fit_resets_online_momentum(smooth_data: Data) -> None:
    x, y = smooth_data
    net = FeedForwardNet(12, 8, 4)
    fit(net, x, y, iterations=1)
    net.partial_fit(x[:5], y[:5])
    assert np.any(net._velocity != 0)
    fit(net, x, y, iterations=1)
    assert np.all(net._velocity == 0)


class _ScriptedNet:
    """Just what `run_training` reads of a network: its weights (here the iteration number)
    and a validation MSE scripted per iteration."""

    def __init__(self, val_mse: list[float]) -> None:
        self.val_mse = val_mse
        self.theta = np.zeros(1)

    def get_theta(self) -> np.ndarray:
        return self.theta.copy()

    def set_theta(self, theta: np.ndarray) -> None:
        self.theta = np.array(theta)

    def validation_mse(self) -> float:
        return self.val_mse[int(self.theta[0])]


class _CountingStep:
    """A training step whose weights count the iterations; training MSE always falls."""

    def __init__(self, net: _ScriptedNet) -> None:
        self.net = net

    def start(self, history: FitHistory) -> float:
        return 1.0

    def step(self) -> float:
        self.net.theta = self.net.theta + 1
        return 1.0 / (1.0 + self.net.theta[0])


def _run_scripted(val_mse: list[float], *, max_fail: int, min_iterations: int,
                  iterations: int = 100) -> tuple[FitHistory, _ScriptedNet]:
    net = _ScriptedNet(val_mse + [val_mse[-1]] * (iterations + 1 - len(val_mse)))
    history = run_training(net, 'lm', _CountingStep(net), iterations=iterations, goal=0.0,
                           validation_mse=net.validation_mse, max_fail=max_fail,
                           callback=None, min_iterations=min_iterations)
    return history, net


def test_validation_failures_count_only_after_min_iterations() -> None:
    # LM's first steps: the validation error rises for 10 iterations, then falls to a best
    # at iteration 15, then rises for good
    val = [1.0] + [1.0 + 0.1 * i for i in range(1, 11)] + [0.9, 0.8, 0.7, 0.6, 0.5] + [0.6]
    history, _ = _run_scripted(val, max_fail=6, min_iterations=0)
    assert history.stop_reason == 'validation' and history.iterations == 6  # MATLAB's rule
    assert history.best_iteration == 0
    history, net = _run_scripted(val, max_fail=6, min_iterations=10)
    assert history.stop_reason == 'validation'
    assert history.iterations == 15 + 6  # 6 failures after the best at 15
    assert history.best_iteration == 15 and net.theta[0] == 15  # its weights restored


def test_min_iterations_then_patience() -> None:
    # never better than at the start: stops exactly min_iterations + max_fail in
    val = [1.0] + [2.0] * 100
    for min_iterations, max_fail in ((0, 6), (20, 6), (20, 25), (90, 25)):
        history, net = _run_scripted(val, max_fail=max_fail, min_iterations=min_iterations)
        expected = min(min_iterations + max_fail, 100)
        assert history.iterations == expected
        assert history.stop_reason == ('validation' if expected < 100 else 'iterations')
        assert history.best_iteration == 0 and net.theta[0] == 0
    # a best during the first iterations is kept even when nothing better comes after
    val = [1.0, 0.5] + [2.0] * 100
    history, net = _run_scripted(val, max_fail=3, min_iterations=10)
    assert (history.iterations, history.best_iteration, net.theta[0]) == (13, 1, 1)


def test_fit_takes_min_iterations(smooth_data: Data) -> None:
    x, y = smooth_data
    rng = np.random.default_rng(1)
    xv = rng.uniform(-1, 1, (50, 12))
    yv = rng.normal(size=(50, 4)) * 10  # unrelated to x: validation cannot improve for long
    net = FeedForwardNet(12, 8, 4)
    history = fit(net, x, y, iterations=60, validation=(xv, yv), max_fail=2, min_iterations=30)
    assert history.iterations >= 32
    with pytest.raises(ValueError, match='min_iterations'):
        fit(net, x, y, min_iterations=-1)


def test_fit_passes_weight_decay_to_lm_only(smooth_data: Data) -> None:
    x, y = smooth_data
    norms = []
    for decay in (0.0, 50.0):
        net = FeedForwardNet(12, 6, 4, 'sigmoid', seed=2)
        fit(net, x, y, iterations=20, weight_decay=decay)
        norms.append(np.linalg.norm(net.theta))
    assert norms[1] < norms[0]
    with pytest.raises(ValueError, match='weight_decay'):
        fit(FeedForwardNet(12, 6, 4, 'sigmoid'), x, y, algorithm='gd', weight_decay=1.0)
