"""Hidden-layer activations of the paper's three networks and their derivatives.

Every activation is a gain ``k`` times a signed sum of shifted logistic sigmoids
σ(z) = 1 / (1 + e^−z):

========== =================================================== =====================
name       f(z)                                                paper
========== =================================================== =====================
sigmoid    k·σ(z)                                              FFS (classic BP)
slog       k·[σ(z+2) − σ(z+3) − σ(z−3) + σ(z−1)]               FFW, eq. 1
mslog      k·slog(z), K = 2.5 by default                       FFMW, eq. 2 and 3
========== =================================================== =====================

The network feeds them z = (x·v + c − b) / a (``c`` a trainable hidden bias, ``a`` and ``b``
fixed constants, eq. 2). Default constants per activation are in `DEFAULT_CONSTANTS`.

`ACTIVATIONS` and `DERIVATIVES` map each name to ``f(z, k)`` and ``f'(z, k)`` (the derivative
with respect to z). Unlike scikit-learn's tables, the derivatives take z, not f(z): a sum of
sigmoids cannot be differentiated from its value alone. These reference functions are exact
to rounding for any z (no overflow, no warnings, tails not flushed to zero); the network's
hot path uses the equivalent form σ(u) = (1 + tanh(u/2))/2, which needs one transcendental
call for all four terms of SLOG and agrees with them to ~1e-16 absolute.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = [
    'ACTIVATIONS',
    'ActivationConstants',
    'DEFAULT_CONSTANTS',
    'DERIVATIVES',
    'LOGISTIC_TERMS',
    'logistic',
    'logistic_derivative',
    'mslog',
    'mslog_derivative',
    'sigmoid',
    'sigmoid_derivative',
    'slog',
    'slog_derivative',
]

FloatArray = npt.NDArray[np.float64]
Activation = Callable[..., FloatArray]


class ActivationConstants(NamedTuple):
    """The constants of eq. 2: h = k·f(z) with z = (x·v + c − b) / a.

    Attributes
    ----------
    k : float
        Output gain of the activation (the paper's K).
    a : float
        Divisor of the net input; must be non-zero.
    b : float
        Offset subtracted from the net input before dividing by ``a``.
    """

    k: float
    a: float
    b: float


#: Default constants: MSLOG as published (K = 2.5, a = b = 5); plain sigmoid and SLOG unscaled.
DEFAULT_CONSTANTS: dict[str, ActivationConstants] = {
    'sigmoid': ActivationConstants(k=1.0, a=1.0, b=0.0),
    'slog': ActivationConstants(k=1.0, a=1.0, b=0.0),
    'mslog': ActivationConstants(k=2.5, a=5.0, b=5.0),
}

_SLOG_SHIFTS = (2.0, 3.0, -3.0, -1.0)
_SLOG_SIGNS = (1.0, -1.0, -1.0, 1.0)

#: Each activation as (shifts, signs): f(z)/k = Σ signs[i]·σ(z + shifts[i]).
LOGISTIC_TERMS: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    'sigmoid': ((0.0,), (1.0,)),
    'slog': (_SLOG_SHIFTS, _SLOG_SIGNS),
    'mslog': (_SLOG_SHIFTS, _SLOG_SIGNS),
}


def logistic(z: npt.ArrayLike) -> FloatArray:
    """Return σ(z) = 1 / (1 + e^−z), accurate in both tails and free of overflow.

    Parameters
    ----------
    z : array_like of any shape

    Returns
    -------
    ndarray of the shape of ``z``
    """
    z = np.asarray(z, dtype=np.float64)
    e = np.exp(-np.abs(z))  # in (0, 1]: never overflows
    result: FloatArray = np.where(z >= 0.0, 1.0 / (1.0 + e), e / (1.0 + e))
    return result


def logistic_derivative(z: npt.ArrayLike) -> FloatArray:
    """Return σ'(z) = e^−|z| / (1 + e^−|z|)², accurate in both tails and free of overflow.

    Parameters
    ----------
    z : array_like of any shape

    Returns
    -------
    ndarray of the shape of ``z``
    """
    e = np.exp(-np.abs(np.asarray(z, dtype=np.float64)))
    return e / (1.0 + e) ** 2


def _logistic_sum(z: npt.ArrayLike, name: str,
                  term: Callable[[FloatArray], FloatArray]) -> FloatArray:
    z = np.asarray(z, dtype=np.float64)
    shifts, signs = LOGISTIC_TERMS[name]
    total = np.zeros_like(z)
    for shift, sign in zip(shifts, signs):
        total += sign * term(z + shift)
    return total


def sigmoid(z: npt.ArrayLike, k: float = 1.0) -> FloatArray:
    """Return k·σ(z), the FFS hidden activation.

    Parameters
    ----------
    z : array_like of any shape
        Net input (x·v + c − b) / a.
    k : float, default 1.0
        Gain.

    Returns
    -------
    ndarray of the shape of ``z``
    """
    return k * logistic(z)


def sigmoid_derivative(z: npt.ArrayLike, k: float = 1.0) -> FloatArray:
    """Return d/dz k·σ(z) = k·σ(z)(1 − σ(z)); same shapes as `sigmoid`."""
    return k * logistic_derivative(z)


def slog(z: npt.ArrayLike, k: float = 1.0) -> FloatArray:
    """Return k·SLOG(z) = k·[σ(z+2) − σ(z+3) − σ(z−3) + σ(z−1)], eq. 1 (FFW).

    Parameters
    ----------
    z : array_like of any shape
        Net input (x·v + c − b) / a.
    k : float, default 1.0
        Gain.

    Returns
    -------
    ndarray of the shape of ``z``
    """
    return k * _logistic_sum(z, 'slog', logistic)


def slog_derivative(z: npt.ArrayLike, k: float = 1.0) -> FloatArray:
    """Return d/dz k·SLOG(z), eq. 3 with K = k; same shapes as `slog`."""
    return k * _logistic_sum(z, 'slog', logistic_derivative)


def mslog(z: npt.ArrayLike, k: float = 2.5) -> FloatArray:
    """Return MSLOG(z) = K·SLOG(z), eq. 2 (FFMW); K defaults to the paper's 2.5.

    Parameters
    ----------
    z : array_like of any shape
        Net input (x·v + c − b) / a, with a = b = 5 in the paper.
    k : float, default 2.5
        The gain K.

    Returns
    -------
    ndarray of the shape of ``z``
    """
    return slog(z, k)


def mslog_derivative(z: npt.ArrayLike, k: float = 2.5) -> FloatArray:
    """Return d/dz MSLOG(z), eq. 3; same shapes as `mslog`."""
    return slog_derivative(z, k)


#: name → f(z, k), see the module docstring.
ACTIVATIONS: dict[str, Activation] = {
    'sigmoid': sigmoid,
    'slog': slog,
    'mslog': mslog,
}

#: name → f'(z, k), the derivative with respect to z (not to f).
DERIVATIVES: dict[str, Activation] = {
    'sigmoid': sigmoid_derivative,
    'slog': slog_derivative,
    'mslog': mslog_derivative,
}
