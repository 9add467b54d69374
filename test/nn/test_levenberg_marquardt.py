"""Levenberg–Marquardt: the structured normal equations and step against dense ones."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.batch import jacobian
from scara_ident_ros.nn.network import forward_scaled
from scara_ident_ros.nn.training import FitHistory
from scara_ident_ros.nn.levenberg_marquardt import (LevenbergMarquardt, normal_blocks,
                                                    normal_equations)


def test_structured_normal_equations_equal_dense_ones(name: str) -> None:
    net = FeedForwardNet(5, 8, 3, name, seed=3)
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-1, 1, (23, 5)), rng.uniform(-1, 1, (23, 3))
    jac = jacobian(net, x)
    r = (forward_scaled(net, x).y - y).ravel()
    jtj, jtr, sse = normal_equations(net, x, y, chunk_size=7)  # several uneven chunks
    np.testing.assert_allclose(jtj, jac.T @ jac, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(jtr, jac.T @ r, rtol=1e-12, atol=1e-12)
    assert sse == pytest.approx(r @ r, rel=1e-12)


@pytest.mark.parametrize('single', [False, True])
@pytest.mark.parametrize('mu', [1e-6, 1e-3, 10.0])
def test_block_solve_equals_the_plain_normal_equations_step(mu: float, single: bool) -> None:
    """The Schur complement on the hidden weights gives the plain (JᵀJ + μI)⁻¹Jᵀr."""
    net = FeedForwardNet(9, 12, 3, 'mslog', seed=5)
    rng = np.random.default_rng(5)
    x, y = rng.uniform(-1, 1, (300, 9)), rng.uniform(-1, 1, (300, 3))
    blocks = normal_blocks(net, x, y, chunk_size=128, single=single)
    jtj, jtr, sse = normal_equations(net, x, y, chunk_size=128, single=single)
    np.testing.assert_array_equal(blocks.matrix(), jtj)
    np.testing.assert_array_equal(blocks.jtr, jtr)
    assert blocks.sse == sse
    damped = jtj + mu * np.eye(net.n_params)
    plain = np.linalg.solve(damped, jtr)
    step = blocks.solve(mu)
    # to rounding: the error a solve of this conditioning may make
    tolerance = 1e-13 * np.linalg.cond(damped) * np.abs(plain).max()
    np.testing.assert_allclose(step, plain, rtol=0, atol=tolerance)
    assert not np.allclose(step, 0.0)


def test_structured_and_plain_lm_take_the_same_steps() -> None:
    rng = np.random.default_rng(6)
    x = rng.uniform(-1, 1, (400, 6))
    y = np.stack([np.sin(2 * x[:, 0]) + x[:, 3], x[:, 1] * x[:, 2]], axis=1)
    nets = [FeedForwardNet(6, 10, 2, 'mslog', seed=6) for _ in range(2)]
    steps = [LevenbergMarquardt(net, x, y, structured=structured)
             for net, structured in zip(nets, (True, False))]
    for step in steps:
        step.set_data(x, y)
    for _ in range(5):
        mses = [step.step() for step in steps]
        assert mses[0] == pytest.approx(mses[1], rel=1e-8)
        assert steps[0].mu == steps[1].mu  # the same accepted and rejected trials
    np.testing.assert_allclose(nets[0].theta, nets[1].theta, rtol=1e-6, atol=1e-9)


def _decay_data() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    x = rng.uniform(-1, 1, (300, 6))
    y = np.stack([np.sin(3 * x[:, 0]) + x[:, 3], x[:, 1] * x[:, 2]], axis=1)
    return x, y + 0.05 * rng.normal(size=y.shape)


@pytest.mark.parametrize('structured', [True, False])
def test_zero_weight_decay_takes_the_old_steps_exactly(structured: bool) -> None:
    x, y = _decay_data()
    nets = [FeedForwardNet(6, 10, 2, 'sigmoid', seed=8) for _ in range(2)]
    steps = [LevenbergMarquardt(nets[0], x, y, structured=structured),
             LevenbergMarquardt(nets[1], x, y, structured=structured, weight_decay=0.0)]
    for step in steps:
        step.set_data(x, y)
    for _ in range(8):
        assert steps[0].step() == steps[1].step()
    np.testing.assert_array_equal(nets[0].theta, nets[1].theta)


def test_weight_decay_shrinks_the_weights_and_lowers_the_penalised_loss() -> None:
    x, y = _decay_data()
    norms, losses = {}, {}
    for decay in (0.0, 1.0, 30.0):
        net = FeedForwardNet(6, 10, 2, 'sigmoid', seed=8)
        step = LevenbergMarquardt(net, x, y, weight_decay=decay)
        step.set_data(x, y)
        for _ in range(40):
            step.step()
        norms[decay] = float(np.linalg.norm(net.theta))
        losses[decay] = step._loss
        mse = float(np.mean((forward_scaled(net, x).y - y) ** 2))
        assert losses[decay] == pytest.approx(mse * y.size + decay * norms[decay] ** 2)
    assert norms[30.0] < norms[1.0] < norms[0.0]


def test_weight_decay_step_solves_the_augmented_system() -> None:
    """δ = (JᵀJ + (μ + λ)I)⁻¹ (Jᵀr + λθ) at the accepted μ, structured and plain alike."""
    x, y = _decay_data()
    decay = 0.7
    net = FeedForwardNet(6, 10, 2, 'sigmoid', seed=8)
    jac = jacobian(net, x)
    r = (forward_scaled(net, x).y - y).ravel()
    before = net.get_theta()
    for structured in (True, False):
        step = LevenbergMarquardt(net, x, y, weight_decay=decay, structured=structured)
        history = FitHistory('lm')
        step.start(history)
        step.step()
        mu = history.mu[-1]
        expected = np.linalg.solve(jac.T @ jac + (mu + decay) * np.eye(net.n_params),
                                   jac.T @ r + decay * before)
        np.testing.assert_allclose(before - net.theta, expected, rtol=1e-6, atol=1e-10)
        net.set_theta(before)


def test_weight_decay_must_be_non_negative() -> None:
    x, y = _decay_data()
    with pytest.raises(ValueError, match='weight_decay'):
        LevenbergMarquardt(FeedForwardNet(6, 4, 2, 'sigmoid'), x, y, weight_decay=-1.0)
