"""FeedForwardNet: shapes, seeds, gradients and Jacobian against central differences,
the online step."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.levenberg_marquardt import (LevenbergMarquardt, normal_blocks,
                                                normal_equations)

NAMES = ('sigmoid', 'slog', 'mslog')


def scaled_net(name: str = 'mslog', **options: float) -> FeedForwardNet:
    net = FeedForwardNet(12, 40, 4, name, **options)  # type: ignore[arg-type]
    net.set_scaling(-np.ones(12), np.ones(12), -np.ones(4), np.ones(4))
    return net


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
    np.testing.assert_array_equal(a.get_params(), b.get_params())
    assert not np.array_equal(a.get_params(), FeedForwardNet(12, 40, 4, seed=8).get_params())


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


@pytest.mark.parametrize('name', NAMES)
def test_loss_gradient_matches_central_differences(name: str) -> None:
    net = FeedForwardNet(12, 40, 4, name, seed=1)
    rng = np.random.default_rng(1)
    xs, ys = rng.uniform(-1, 1, (20, 12)), rng.uniform(-1, 1, (20, 4))
    theta = net.get_params()
    sse, grad = net.loss_gradient(xs, ys)
    assert sse == pytest.approx(net.mse_scaled(xs, ys) * ys.size, rel=1e-12)

    def loss(t: np.ndarray) -> float:
        return net.mse_scaled(xs, ys, t) * ys.size / (2 * len(xs))

    step = 1e-6
    numeric = np.empty_like(theta)
    for i in range(theta.size):
        plus, minus = theta.copy(), theta.copy()
        plus[i] += step
        minus[i] -= step
        numeric[i] = (loss(plus) - loss(minus)) / (2 * step)
    np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-9)


@pytest.mark.parametrize('name', NAMES)
def test_jacobian_matches_central_differences(name: str) -> None:
    net = FeedForwardNet(4, 6, 3, name, seed=2)
    x = np.random.default_rng(2).uniform(-1, 1, (5, 4))
    jac = net.jacobian(x)
    assert jac.shape == (5 * 3, net.n_params)
    theta = net.get_params()
    step = 1e-6
    numeric = np.empty_like(jac)
    for i in range(theta.size):
        plus, minus = theta.copy(), theta.copy()
        plus[i] += step
        minus[i] -= step
        numeric[:, i] = ((net.forward_scaled(x, plus).y - net.forward_scaled(x, minus).y)
                         / (2 * step)).ravel()
    np.testing.assert_allclose(jac, numeric, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize('name', NAMES)
def test_structured_normal_equations_equal_dense_ones(name: str) -> None:
    net = FeedForwardNet(5, 8, 3, name, seed=3)
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-1, 1, (23, 5)), rng.uniform(-1, 1, (23, 3))
    jac = net.jacobian(x)
    r = (net.forward_scaled(x).y - y).ravel()
    jtj, jtr, sse = normal_equations(net, x, y, chunk_size=7)  # several uneven chunks
    np.testing.assert_allclose(jtj, jac.T @ jac, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(jtr, jac.T @ r, rtol=1e-12, atol=1e-12)
    assert sse == pytest.approx(r @ r, rel=1e-12)


@pytest.mark.parametrize('name', NAMES)
def test_online_step_is_sgd_with_momentum(name: str) -> None:
    net = scaled_net(name, learning_rate=0.01, momentum=0.5, seed=4)
    rng = np.random.default_rng(4)
    x, y = rng.uniform(-1, 1, (2, 12)), rng.uniform(-1, 1, (2, 4))
    theta0 = net.get_params()
    _, g0 = net.loss_gradient(x[:1], y[:1])
    prior = net.predict(x[0])
    error = net.partial_fit(x[0], y[0])
    np.testing.assert_allclose(error, y[0] - prior, rtol=1e-12, atol=1e-14)
    theta1 = net.get_params()
    np.testing.assert_allclose(theta1, theta0 - 0.01 * g0, rtol=1e-11, atol=1e-15)
    _, g1 = net.loss_gradient(x[1:], y[1:])
    net.partial_fit(x[1], y[1])
    expected = theta1 + 0.5 * (theta1 - theta0) - 0.01 * g1
    np.testing.assert_allclose(net.get_params(), expected, rtol=1e-11, atol=1e-15)


def test_online_step_learns_in_physical_units() -> None:
    net = FeedForwardNet(2, 3, 1, learning_rate=0.1, momentum=0.0)
    net.set_scaling([0, 0], [10, 10], [0], [100])
    theta0 = net.get_params()
    x, y = np.array([2.0, 7.0]), np.array([30.0])
    xs, ys = np.array([[-0.6, 0.4]]), np.array([[-0.4]])
    _, grad = net.loss_gradient(xs, ys)
    net.partial_fit(x, y)
    np.testing.assert_allclose(net.get_params(), theta0 - 0.1 * grad, rtol=1e-12)


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
    np.testing.assert_array_equal(a.get_params(), b.get_params())


def test_partial_fit_needs_scaling() -> None:
    net = FeedForwardNet(12, 40, 4)
    with pytest.raises(RuntimeError, match='set_scaling'):
        net.partial_fit(np.zeros(12), np.zeros(4))


@pytest.mark.filterwarnings('ignore:invalid value:RuntimeWarning')
def test_non_finite_sample_is_refused_and_changes_nothing() -> None:
    net = scaled_net()
    net.partial_fit(np.full(12, 0.1), np.full(4, 0.2))  # some momentum
    theta, velocity = net.get_params(), net._velocity.copy()
    for x, y in ((np.full(12, np.nan), np.zeros(4)), (np.zeros(12), np.array([0, np.inf, 0, 0])),
                 (np.full(12, np.inf), np.zeros(4))):
        with pytest.raises(ValueError, match='non-finite'):
            net.partial_fit(x, y)
        np.testing.assert_array_equal(net.get_params(), theta)
        np.testing.assert_array_equal(net._velocity, velocity)


def test_learning_rate_and_momentum_can_change_online() -> None:
    net = scaled_net(momentum=0.0)
    net.learning_rate = 0.0125
    theta0 = net.get_params()
    x, y = np.full(12, 0.3), np.full(4, -0.2)
    _, grad = net.loss_gradient(x[None], y[None])
    net.partial_fit(x, y)
    np.testing.assert_allclose(net.get_params(), theta0 - 0.0125 * grad, rtol=1e-11)
    with pytest.raises(ValueError):
        net.learning_rate = -1.0


@pytest.mark.parametrize('name', NAMES)
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


def test_step_units_are_steps_of_one_input_at_zero() -> None:
    """``set_step_units``: unit u is k·σ(2·x_i / w) of its input alone; the others and the
    output layer keep their weights."""
    net = FeedForwardNet(6, 10, 2, 'sigmoid', seed=1)
    before = net.get_params()
    net.set_step_units([2, 3], [0.1, 0.01])
    xs = np.random.default_rng(0).uniform(-1, 1, (200, 6))
    h = net.forward_scaled(xs).h
    k = net.constants.k
    for unit, (width, column) in enumerate([(0.1, 2), (0.1, 3), (0.01, 2), (0.01, 3)]):
        np.testing.assert_allclose(h[:, unit], k / (1 + np.exp(-2 * xs[:, column] / width)),
                                   rtol=1e-12, atol=1e-15)
    Vt_before, Wt_before = net.unpack(before)
    Vt, Wt = net.unpack(net.theta)
    np.testing.assert_array_equal(Vt[:, 4:], Vt_before[:, 4:])
    np.testing.assert_array_equal(Wt, Wt_before)


@pytest.mark.parametrize('inputs, widths, match', [
    ([6], [0.1], 'inputs'), ([0], [0.0], 'widths'), ([0], [float('nan')], 'widths'),
    ([0, 1, 2, 3], [0.1, 0.2, 0.3], 'hidden units')])
def test_step_units_refuse_what_they_cannot_build(inputs: list[int], widths: list[float],
                                                  match: str) -> None:
    net = FeedForwardNet(6, 10, 2, 'sigmoid')
    before = net.get_params()
    with pytest.raises(ValueError, match=match):
        net.set_step_units(inputs, widths)
    np.testing.assert_array_equal(net.theta, before)


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
