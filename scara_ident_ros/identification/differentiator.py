"""Joint acceleration from joint velocity by filtered differentiation.

Robots publish q and q' but not q''; the network's input needs q''. Each method below uses the
samples' actual times (integer nanoseconds), so it stays correct when stamps are uneven, and
works on all joints at once.

Methods and the delay each introduces, for a uniform sampling period ``T`` (the delay is the
time by which the estimate lags the true q'' when q'' is a ramp; see :meth:`Differentiator.delay`):

``'backward'``
    ``(v_k - v_{k-1}) / (t_k - t_{k-1})``. Exact for a velocity that is linear in time; for any
    quadratic velocity it is exactly q'' at the interval's midpoint: delay ``T / 2``. No noise
    attenuation: white velocity noise of std ``s`` gives acceleration noise ``s * sqrt(2) / T``.
``'lowpass'``
    The backward difference followed by a first-order low-pass of cutoff ``f_c`` Hz, time
    constant ``tau = 1 / (2 pi f_c)``, discretised exactly for each interval as
    ``y_k = y_{k-1} + alpha_k (d_k - y_{k-1})`` with ``alpha_k = 1 - exp(-dt_k / tau)``, so the
    filter is the same continuous-time filter whatever the stamps. The filter starts at the
    first difference, so a constant q'' passes without a transient. Delay
    ``T / 2 + T / (exp(T / tau) - 1)``, about ``tau`` when ``T << tau``; the noise std of the
    backward difference is multiplied by ``alpha / sqrt(2 - alpha)`` (uniform stamps).
``'polynomial'``
    Savitzky–Golay-like: a least-squares polynomial of degree ``p`` fitted to the last ``W``
    velocities at their actual times, differentiated at the newest sample. Exact (no delay)
    for velocities that are polynomials of degree up to ``p``; with ``p = 1`` (a straight line)
    the slope is that of the window's mean time, delay ``(W - 1) T / 2``. Higher ``p`` and
    smaller ``W`` cost noise: the std is ``s * sqrt(sum(w_i ** 2))`` for the fit's weights
    ``w``, larger than that of a centred (delayed) Savitzky–Golay filter.

:data:`DIFFERENTIATORS` names these and the zero-lag ``'centred'`` fit
(:class:`~scara_ident_ros.identification.centred_differentiator.CentredDifferentiator`, the
default); :func:`make_differentiator` builds any of them.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.identification.centred_differentiator import (DIFFERENTIATOR_WINDOW,
                                                                   CentredDifferentiator)

__all__ = ['AccelerationEstimate', 'CAUSAL_DIFFERENTIATORS', 'CUTOFF_HZ', 'DIFFERENTIATORS',
           'DIFFERENTIATOR_WINDOW', 'Differentiator', 'make_differentiator']

#: Names of the acceleration estimates: ``'centred'`` (:class:`CentredDifferentiator`, the
#: zero-lag default), then the causal ones of :class:`Differentiator`.
DIFFERENTIATORS = ('centred', 'lowpass', 'backward', 'polynomial')
CAUSAL_DIFFERENTIATORS = DIFFERENTIATORS[1:]
CUTOFF_HZ = 50.0  # Hz: the lowpass differentiator's cut-off (the node's ``cutoff_hz``)
NS = 1e-9  # seconds per nanosecond


class Differentiator:
    """Estimate q'' from a stream of timed q' samples, for all joints at once.

    Parameters
    ----------
    method : {'backward', 'lowpass', 'polynomial'}
        See the module documentation for each method's delay and noise.
    cutoff_hz : float
        Cutoff frequency of ``'lowpass'``, Hz.
    window : int
        Number of samples ``W`` fitted by ``'polynomial'``; at least ``degree + 1``.
    degree : int
        Degree ``p`` of the ``'polynomial'`` fit, at least 1.

    Notes
    -----
    :meth:`update` returns None while warming up: for the first sample (and the first after
    :meth:`reset`) with ``'backward'`` and ``'lowpass'``, for the first ``W - 1`` with
    ``'polynomial'``. The number of joints is fixed by the first sample (until a reset).
    """

    def __init__(self, method: str = 'lowpass', *, cutoff_hz: float = CUTOFF_HZ,
                 window: int = 7,
                 degree: int = 2) -> None:
        if method not in CAUSAL_DIFFERENTIATORS:
            raise ValueError(f'unknown differentiation method {method!r}; choose from '
                             f'{CAUSAL_DIFFERENTIATORS}')
        if not (math.isfinite(cutoff_hz) and cutoff_hz > 0.0):
            raise ValueError(f'cutoff_hz must be positive and finite, got {cutoff_hz}')
        if degree < 1 or window < degree + 1:
            raise ValueError(f'polynomial fit needs degree >= 1 and window >= degree + 1, got '
                             f'degree {degree}, window {window}')
        self.method = method
        self.cutoff_hz = float(cutoff_hz)
        self.window = int(window)
        self.degree = int(degree)
        self._tau_ns = 1e9 / (2.0 * math.pi * self.cutoff_hz)  # low-pass time constant, ns
        self._update: Callable[[int, NDArray[np.float64]], NDArray[np.float64] | None] = {
            'backward': self._update_backward,
            'lowpass': self._update_lowpass,
            'polynomial': self._update_polynomial,
        }[method]
        self._n = 0
        self.reset()

    def reset(self) -> None:
        """Forget the history: the next sample starts a new one (and yields None)."""
        self._count = 0  # samples in the current history
        self._last_t = 0  # ns
        self._last_v = np.empty(0)
        self._y = np.empty(0)  # 'lowpass' state: filtered acceleration
        self._t = np.empty(0, dtype=np.int64)  # 'polynomial' ring buffer of stamps, ns
        # 'polynomial' ring buffer (W, p + 1 + n): the fit's basis, then the velocities.
        self._fit = np.empty((0, 0))

    def update(self, stamp_ns: int, velocity: ArrayLike) -> NDArray[np.float64] | None:
        """Add one velocity sample and return the acceleration estimate.

        Parameters
        ----------
        stamp_ns : int
            Time of the sample, integer nanoseconds; later than the previous sample's.
        velocity : array_like of shape (n,)
            Joint velocities q', rad/s or m/s. They must be finite, which is not checked
            here (a NaN would poison ``'lowpass'`` until a reset): the caller validates each
            sample once, as :class:`~scara_ident_ros.identification.SampleCheck` does.

        Returns
        -------
        ndarray of shape (n,) or None
            The acceleration q'' (rad/s² or m/s², a new array), or None while warming up.

        Raises
        ------
        ValueError
            If the stamp does not increase or the joint count changes; the state is then left
            as it was.
        """
        v = np.asarray(velocity, dtype=np.float64)
        if self._count == 0:
            if v.ndim != 1 or v.size == 0:
                raise ValueError(f'velocity must have shape (n,) with n >= 1, got {v.shape}')
            self._n = v.size
        elif v.shape != (self._n,):
            raise ValueError(f'velocity must have shape ({self._n},), got {v.shape}')
        elif stamp_ns <= self._last_t:
            raise ValueError(f'stamp {stamp_ns} ns does not follow {self._last_t} ns')
        return self._update(stamp_ns, v)

    def delay(self, period_s: float) -> float:
        """Return the delay of the estimate for a uniform sampling period.

        Parameters
        ----------
        period_s : float
            Sampling period T, s.

        Returns
        -------
        float
            Time, s, by which the estimate lags the true q'' when q'' is a ramp (its
            steady-state lag for ``'lowpass'``).
        """
        if self.method == 'backward':
            return period_s / 2.0
        if self.method == 'lowpass':
            return period_s / 2.0 + period_s / math.expm1(period_s / (self._tau_ns * NS))
        return 0.0 if self.degree >= 2 else (self.window - 1) * period_s / 2.0

    def _update_backward(self, t: int, v: NDArray[np.float64]) -> NDArray[np.float64] | None:
        acc = None if self._count == 0 else (v - self._last_v) / ((t - self._last_t) * NS)
        self._last_t, self._last_v = t, v.copy()
        self._count += 1
        return acc

    def _update_lowpass(self, t: int, v: NDArray[np.float64]) -> NDArray[np.float64] | None:
        if self._count == 0:
            acc = None
        else:
            dt = t - self._last_t
            diff = (v - self._last_v) / (dt * NS)
            if self._count == 1:
                self._y = diff
            else:
                self._y += -math.expm1(-dt / self._tau_ns) * (diff - self._y)
            acc = self._y.copy()
        self._last_t, self._last_v = t, v.copy()
        self._count += 1
        return acc

    def _update_polynomial(self, t: int, v: NDArray[np.float64]) -> NDArray[np.float64] | None:
        w, p = self.window, self.degree
        fit = self._fit
        if self._count == 0:
            self._t = np.empty(w, dtype=np.int64)
            self._fit = fit = np.empty((w, p + 1 + self._n))
            fit[:, 0] = 1.0
        # The fit does not depend on the order of its points: overwrite the oldest in place.
        self._t[self._count % w] = t
        fit[self._count % w, p + 1:] = v
        self._last_t = t
        self._count += 1
        if self._count < w:
            return None
        span = t - int(self._t[self._count % w])  # ns, newest minus oldest stamp
        # Basis ((t_i - t) / span) ** j, in [-1, 0]: well conditioned for any stamps.
        np.divide(self._t - t, span, out=fit[:, 1])  # exact integer differences first
        for j in range(2, p + 1):
            np.multiply(fit[:, j - 1], fit[:, 1], out=fit[:, j])
        normal = fit[:, :p + 1].T @ fit  # (p + 1, p + 1 + n): [B'B | B'V]
        coef = np.linalg.solve(normal[:, :p + 1], normal[:, p + 1:])  # (p + 1, n)
        return cast(NDArray[np.float64], coef[1] / (span * NS))


AccelerationEstimate = Differentiator | CentredDifferentiator


def make_differentiator(method: str = 'centred', *, window: int = DIFFERENTIATOR_WINDOW,
                        cutoff_hz: float = CUTOFF_HZ, degree: int = 2) -> AccelerationEstimate:
    """Build the acceleration estimate called ``method`` (one of :data:`DIFFERENTIATORS`).

    Parameters
    ----------
    method : str
        ``'centred'`` (zero-phase, :class:`CentredDifferentiator`) or a causal
        :class:`Differentiator` method.
    window : int
        Samples per polynomial fit (``'centred'``: odd; ``'polynomial'``).
    cutoff_hz : float
        Cut-off of ``'lowpass'`` (Hz).
    degree : int
        Polynomial degree (``'centred'``, ``'polynomial'``).
    """
    if method == 'centred':
        return CentredDifferentiator(window, degree)
    if method not in DIFFERENTIATORS:
        raise ValueError(f'unknown differentiator {method!r}; choose from {DIFFERENTIATORS}')
    return Differentiator(method, cutoff_hz=cutoff_hz, window=window, degree=degree)
