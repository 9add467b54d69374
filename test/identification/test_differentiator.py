"""Tests of the filtered differentiators: exactness on polynomials, delay, noise, reset."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from scara_ident_ros.identification.differentiator import CAUSAL_DIFFERENTIATORS, Differentiator

T0 = 1_700_000_000_000_000_000  # ns: a wall-clock epoch stamp, to exercise large integers
PERIOD_NS = 1_000_000  # 1 kHz
PERIOD = PERIOD_NS * 1e-9  # s


def uneven_stamps(count: int, seed: int = 0) -> NDArray[np.int64]:
    """Stamps at 1 kHz with ±40 % jitter, integer ns, starting at ``T0``."""
    rng = np.random.default_rng(seed)
    steps = rng.integers(600_000, 1_400_000, size=count)
    return T0 + np.cumsum(steps)


def run(diff: Differentiator, stamps: NDArray[np.int64],
        velocity: NDArray[np.float64]) -> list[NDArray[np.float64] | None]:
    return [diff.update(int(t), v) for t, v in zip(stamps, velocity, strict=True)]


def seconds(stamps: NDArray[np.int64]) -> NDArray[np.float64]:
    """Time since ``T0`` in s (exact integer difference first)."""
    return (stamps - T0).astype(np.float64) * 1e-9


@pytest.mark.parametrize('method', CAUSAL_DIFFERENTIATORS)
def test_exact_on_a_linear_velocity_with_uneven_stamps(method: str) -> None:
    stamps = uneven_stamps(60)
    slope = np.array([2.0, -0.5, 0.0, 7.25])  # rad/s², m/s²
    velocity = np.array([0.3, -1.0, 0.1, 2.0]) + np.outer(seconds(stamps), slope)
    diff = Differentiator(method, cutoff_hz=30.0, window=5, degree=2)
    out = run(diff, stamps, velocity)
    warm = 4 if method == 'polynomial' else 1
    assert all(a is None for a in out[:warm])
    for a in out[warm:]:
        assert a is not None
        np.testing.assert_allclose(a, slope, rtol=1e-7, atol=1e-7)


def test_backward_is_exact_at_the_midpoint_of_a_quadratic_velocity() -> None:
    stamps = uneven_stamps(40, seed=1)
    t = seconds(stamps)
    c = np.array([3.0, -2.0])  # acceleration = c * t
    velocity = 0.5 * np.outer(t * t, c) + 1.0
    out = run(Differentiator('backward'), stamps, velocity)
    mid = 0.5 * (t[1:] + t[:-1])
    np.testing.assert_allclose(np.array(out[1:]), np.outer(mid, c), rtol=1e-6)


@pytest.mark.parametrize('degree', [1, 2, 3])
def test_polynomial_fit_is_exact_on_a_polynomial_of_its_degree(degree: int) -> None:
    stamps = uneven_stamps(30, seed=degree)
    t = seconds(stamps)
    coef = np.array([[0.2, -0.4], [1.5, 0.7], [-3.0, 2.0], [4.0, -1.0]])[:degree + 1]
    velocity = np.stack([np.polynomial.polynomial.polyval(t, coef[:, j]) for j in (0, 1)], 1)
    acceleration = np.stack(
        [np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyder(coef[:, j]))
         for j in (0, 1)], 1)
    out = run(Differentiator('polynomial', window=degree + 4, degree=degree), stamps, velocity)
    warm = degree + 3
    assert all(a is None for a in out[:warm])
    np.testing.assert_allclose(np.array(out[warm:]), acceleration[warm:], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize('method, options', [
    ('backward', {}),
    ('lowpass', {'cutoff_hz': 20.0}),
    ('lowpass', {'cutoff_hz': 300.0}),
    ('polynomial', {'window': 9, 'degree': 1}),
    ('polynomial', {'window': 9, 'degree': 2}),
])
def test_delay_matches_the_documented_value(method: str, options: dict[str, Any]) -> None:
    stamps = T0 + PERIOD_NS * np.arange(1, 801)
    t = seconds(stamps)
    c = 4.0  # q'' = c t: a ramp, whose estimate lags by the delay
    velocity = (0.5 * c * t * t)[:, np.newaxis]
    diff = Differentiator(method, **options)
    out = run(diff, stamps, velocity)
    delay = diff.delay(PERIOD)
    assert out[-1] is not None
    np.testing.assert_allclose(out[-1], c * (t[-1] - delay), rtol=1e-7)
    if method == 'lowpass' and options['cutoff_hz'] < 50.0:  # tau >> T: delay about tau
        tau = 1.0 / (2.0 * math.pi * options['cutoff_hz'])
        assert delay == pytest.approx(tau, rel=0.01)


def noise_std(diff: Differentiator, sigma: float, count: int = 40_000) -> float:
    rng = np.random.default_rng(7)
    stamps = T0 + PERIOD_NS * np.arange(count)
    out = [a for a in run(diff, stamps, rng.normal(0.0, sigma, (count, 1))) if a is not None]
    return float(np.std(np.array(out)[200:]))


def test_backward_noise_gain() -> None:
    sigma = 1e-3
    assert noise_std(Differentiator('backward'), sigma) == pytest.approx(
        sigma * math.sqrt(2.0) / PERIOD, rel=0.03)


@pytest.mark.parametrize('cutoff_hz', [10.0, 50.0])
def test_lowpass_attenuates_noise_as_designed(cutoff_hz: float) -> None:
    sigma = 1e-3
    alpha = -math.expm1(-PERIOD * 2.0 * math.pi * cutoff_hz)
    expected = sigma * math.sqrt(2.0) / PERIOD * alpha / math.sqrt(2.0 - alpha)
    assert noise_std(Differentiator('lowpass', cutoff_hz=cutoff_hz), sigma) == pytest.approx(
        expected, rel=0.05)


def test_polynomial_noise_gain_is_that_of_its_least_squares_weights() -> None:
    window, degree, sigma = 11, 2, 1e-3
    # The weights of the slope at the newest sample (time 0: the fit's linear coefficient),
    # from numpy's own least squares fit of each unit impulse.
    times = PERIOD * np.arange(-(window - 1), 1)
    weights = [np.polyfit(times, unit, degree)[-2] for unit in np.eye(window)]
    expected = sigma * math.sqrt(sum(w * w for w in weights))
    diff = Differentiator('polynomial', window=window, degree=degree)
    assert noise_std(diff, sigma) == pytest.approx(expected, rel=0.03)
    assert expected < sigma * math.sqrt(2.0) / PERIOD  # it does attenuate


@pytest.mark.parametrize('method', CAUSAL_DIFFERENTIATORS)
def test_reset_forgets_the_history(method: str) -> None:
    stamps = uneven_stamps(50, seed=3)
    t = seconds(stamps)
    diff = Differentiator(method, window=5, degree=1)
    run(diff, stamps[:25], np.outer(t[:25], [10.0, -10.0]))  # a steep ramp, then a reset
    diff.reset()
    out = run(diff, stamps[25:], np.outer(t[25:], [1.0, 2.0]) + 5.0)
    warm = 4 if method == 'polynomial' else 1
    assert all(a is None for a in out[:warm])
    np.testing.assert_allclose(np.array(out[warm:]), np.tile([1.0, 2.0], (25 - warm, 1)),
                               rtol=1e-6)


@pytest.mark.parametrize('method', CAUSAL_DIFFERENTIATORS)
def test_a_refused_update_leaves_the_state_unchanged(method: str) -> None:
    stamps = uneven_stamps(20, seed=4)
    velocity = np.outer(seconds(stamps) ** 2, [1.0, 3.0])
    ref = run(Differentiator(method, window=4), stamps, velocity)
    diff = Differentiator(method, window=4)
    out = []
    for k, (t, v) in enumerate(zip(stamps, velocity, strict=True)):
        if k > 5:
            with pytest.raises(ValueError, match='does not follow'):
                diff.update(int(stamps[k - 1]), v + 1.0)  # repeated stamp
            with pytest.raises(ValueError, match='shape'):
                diff.update(int(t), np.ones(3))  # joint count changed
        out.append(diff.update(int(t), v))
    for a, b in zip(out, ref, strict=True):
        assert (a is None and b is None) or (a is not None and b is not None
                                             and np.array_equal(a, b))


def test_vectorised_over_any_joint_count() -> None:
    stamps = uneven_stamps(10)
    for n in (1, 6):
        slope = np.arange(1.0, n + 1.0)
        out = run(Differentiator('backward'), stamps, np.outer(seconds(stamps), slope))
        assert out[-1] is not None and out[-1].shape == (n,)
        np.testing.assert_allclose(out[-1], slope, rtol=1e-6)


def test_output_is_a_new_array() -> None:
    diff = Differentiator('lowpass')
    diff.update(T0, [0.0])
    first = diff.update(T0 + PERIOD_NS, [1.0])
    assert first is not None
    first[0] = 123.0
    assert diff.update(T0 + 2 * PERIOD_NS, [2.0]) == pytest.approx([1000.0])


@pytest.mark.parametrize('kwargs', [
    {'method': 'central'}, {'cutoff_hz': 0.0}, {'cutoff_hz': math.inf},
    {'method': 'polynomial', 'degree': 0}, {'method': 'polynomial', 'window': 2, 'degree': 2},
])
def test_bad_configuration_is_refused(kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        Differentiator(**kwargs)  # type: ignore[arg-type]
