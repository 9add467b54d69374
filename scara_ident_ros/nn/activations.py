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
to rounding for any z (no overflow, no warnings, tails not flushed to zero). The network
evaluates the same `LOGISTIC_TERMS` in the equivalent `TanhForm` (σ(u) = (1 + tanh(u/2))/2),
which needs one transcendental call for all four terms of SLOG and agrees with them to
~1e-16 absolute: `hidden_layer` for batches; the per-sample path reads the same coefficients.
The reference functions are several times slower on a batch and on one sample
(docs/results.md), too slow for LM and the 1 kHz path.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = [
    'ACTIVATIONS',
    'ActivationConstants',
    'DEFAULT_CONSTANTS',
    'DERIVATIVES',
    'LOGISTIC_TERMS',
    'TanhForm',
    'hidden_layer',
    'logistic',
    'logistic_derivative',
    'mslog',
    'mslog_derivative',
    'sigmoid',
    'sigmoid_derivative',
    'slog',
    'slog_derivative',
    'tanh_form',
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
    """Return σ'(z) = e^−|z| / (1 + e^−|z|)², accurate in both tails and free of overflow;
    same shapes as `logistic`."""
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
    """Return k·SLOG(z) = k·[σ(z+2) − σ(z+3) − σ(z−3) + σ(z−1)], eq. 1 (FFW); z, k and
    shapes as `sigmoid`'s."""
    return k * _logistic_sum(z, 'slog', logistic)


def slog_derivative(z: npt.ArrayLike, k: float = 1.0) -> FloatArray:
    """Return d/dz k·SLOG(z), eq. 3 with K = k; same shapes as `slog`."""
    return k * _logistic_sum(z, 'slog', logistic_derivative)


def mslog(z: npt.ArrayLike, k: float = 2.5) -> FloatArray:
    """Return MSLOG(z) = K·SLOG(z), eq. 2 (FFMW), with the gain k = K defaulting to the
    paper's 2.5 (whose z has a = b = 5); same shapes as `slog`."""
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


class TanhForm(NamedTuple):
    """An activation of `LOGISTIC_TERMS` with its constants, as the network evaluates it.

    With p = x·v + c the net input, z = (p − b)/a and σ(u) = (1 + tanh(u/2))/2::

        t_i   = tanh(p·scale + offset_i)      scale = 1/(2a), offset_i = (shift_i − b/a)/2
        h     = h_const + Σ h_coef_i·t_i      h_coef_i = k·s_i/2,       h_const = Σ h_coef_i
        dh/dp = g_const + Σ g_coef_i·t_i²     g_coef_i = −k·s_i/(4a),   g_const = −Σ g_coef_i

    ``tau_i = tanh(shift_i/2)`` gives every t_i from T = tanh(z/2) with one tanh:
    t_i = (T + τ_i)/(1 + T·τ_i), where 1 + T·τ_i >= 1 − |τ_i| > 0.
    """

    scale: float
    offset: FloatArray  # (n_terms, 1)
    tau: FloatArray  # (n_terms,)
    h_coef: FloatArray  # (n_terms,)
    h_const: float
    g_coef: FloatArray  # (n_terms,)
    g_const: float
    b: float


def tanh_form(name: str, constants: ActivationConstants) -> TanhForm:
    """Return the `TanhForm` of activation ``name`` with constants (k, a, b)."""
    shifts, signs = (np.array(terms) for terms in LOGISTIC_TERMS[name])
    k, a, b = constants
    return TanhForm(scale=1.0 / (2.0 * a), offset=((shifts - b / a) / 2.0)[:, None],
                    tau=np.tanh(shifts / 2.0), h_coef=k / 2.0 * signs,
                    h_const=k / 2.0 * float(signs.sum()), g_coef=-k / (4.0 * a) * signs,
                    g_const=k / (4.0 * a) * float(signs.sum()), b=b)


def hidden_layer(p: FloatArray, form: TanhForm, *, derivative: bool = False
                 ) -> tuple[FloatArray, FloatArray | None]:
    """Hidden outputs h and, if asked, g = dh/dp of net inputs p = x·v + c.

    Parameters
    ----------
    p : ndarray of shape (n, n_hidden)
        Net inputs; overwritten (with tanh(z/2)).
    form : TanhForm
    derivative : bool
        Also return g.

    Returns
    -------
    h : ndarray of shape (n, n_hidden)
    g : ndarray of shape (n, n_hidden) or None
    """
    T = p
    T -= form.b
    T *= form.scale
    np.tanh(T, out=T)
    h = np.full_like(T, form.h_const)
    g = np.full_like(T, form.g_const) if derivative else None
    t = np.empty_like(T)
    work = np.empty_like(T)
    for tau, h_coef, g_coef in zip(form.tau, form.h_coef, form.g_coef):
        np.multiply(T, tau, out=work)
        work += 1.0
        np.add(T, tau, out=t)
        t /= work
        np.multiply(t, h_coef, out=work)
        h += work
        if g is not None:
            np.multiply(t, t, out=work)
            work *= g_coef
            g += work
    return h, g
