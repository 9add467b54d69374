"""How well the data determine a least-squares fit: each parameter's %σ, the condition number.

For efforts τ = W θ + e fitted by least squares on the regressor W stacked over the samples
(N·n × p), with e independent between samples and of variance σ_j² on joint j, the
estimate's covariance is

    cov(θ̂) = (WᵀW)⁻¹ (Σ_j σ_j² W_jᵀ W_j) (WᵀW)⁻¹,

W_j the rows of joint j. With one σ² for every joint it is the textbook σ² (WᵀW)⁻¹; with
efforts of different noise per joint (a weighted fit would divide joint j's rows by σ_j),
this is the covariance of the unweighted fit the models here make. σ_j² is the residual
variance of joint j, ||τ_j − W_j θ̂||² / (N − p/n) (p/n degrees of freedom per joint).
The relative standard deviation of parameter k is %σ_k = 100 σ_k / |θ_k| (Swevers et al.
1997, Gautier 1990); above :data:`UNDETERMINED_RELATIVE_STD` the data do not determine it:
excite the motion it acts in more. A parameter in the null space of W (a joint that does
not move, so its friction and the inertias only it turns never act) has σ = ∞, and so has
every parameter of a fit with no residual degrees of freedom left (N·n <= p).

The condition number s_max / s_min of W (∞ if singular) is what an excitation minimises
(:mod:`~scara_ident_ros.excitation.optimized_excitation`): the smaller, the less noise is
amplified into θ̂. W is reduced block by block (QR), never formed whole.

Public API::

    UNDETERMINED_RELATIVE_STD
    ParameterUncertainty(names, theta, std, condition_number)
    parameter_uncertainty(model, q, qd, qdd, tau, theta) -> ParameterUncertainty
    condition_number(model, q, qd, qdd) -> float
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.dynamics.base_reduction import RANK_TOLERANCE
from scara_ident_ros.dynamics.least_squares import LinearInParameters

__all__ = ['UNDETERMINED_RELATIVE_STD', 'ParameterUncertainty', 'condition_number',
           'parameter_uncertainty']

FloatArray = NDArray[np.float64]
#: Relative standard deviation σ_k / |θ_k| above which a parameter counts as not determined
#: by the data (10 %).
UNDETERMINED_RELATIVE_STD = 0.10
_BLOCK = 2048  # samples per block


@dataclass(frozen=True)
class ParameterUncertainty:
    """The parameters of a fit with their standard deviations.

    Attributes
    ----------
    names : tuple of str of length p
        The parameters.
    theta : ndarray of shape (p,)
        Their values.
    std : ndarray of shape (p,)
        Standard deviation σ_k of each (its unit); ∞ where the data do not act on it.
    condition_number : float
        s_max / s_min of the stacked regressor (∞ if singular).
    """

    names: tuple[str, ...]
    theta: FloatArray
    std: FloatArray
    condition_number: float

    @property
    def relative_std(self) -> FloatArray:
        """σ_k / |θ_k|, shape (p,) (a fraction; ∞ for θ_k = 0 with σ_k > 0)."""
        with np.errstate(divide='ignore', invalid='ignore'):
            relative = self.std / np.abs(self.theta)
        return np.where(self.std == 0.0, 0.0, relative)

    @property
    def undetermined(self) -> NDArray[np.bool_]:
        """Whether each parameter's σ_k / |θ_k| exceeds :data:`UNDETERMINED_RELATIVE_STD`,
        shape (p,)."""
        return np.asarray(self.relative_std > UNDETERMINED_RELATIVE_STD)

    @property
    def undetermined_names(self) -> tuple[str, ...]:
        """The names of the :attr:`undetermined` parameters."""
        return tuple(name for name, bad in zip(self.names, self.undetermined) if bad)


def parameter_uncertainty(model: LinearInParameters, q: ArrayLike, qd: ArrayLike,
                          qdd: ArrayLike, tau: ArrayLike, theta: ArrayLike, *,
                          names: Sequence[str] = (), weights: ArrayLike | None = None
                          ) -> ParameterUncertainty:
    """The covariance of a least-squares θ fitted to these samples (module docstring).

    Parameters
    ----------
    model : LinearInParameters
        τ = Y(q, q', q'') θ, Y of shape (N, n, p).
    q, qd, qdd : array_like of shape (N, n)
        Joint positions, velocities and accelerations (SI).
    tau : array_like of shape (N, n)
        Measured efforts (N·m, N).
    theta : array_like of shape (p,)
        The fitted parameters.
    names : sequence of str
        The parameters' names (default ``model.parameter_names`` if it has them).
    weights : array_like of shape (n,), optional
        The weight w_j of each joint's rows in the fit (``fit_least_squares``); default 1:
        cov = (WᵀΛW)⁻¹ (Σ_j σ_j² w_j⁴ W_jᵀ W_j) (WᵀΛW)⁻¹, Λ the weights squared per row;
        (WᵀΛW)⁻¹ for w_j = 1/σ_j.

    Raises
    ------
    ValueError
        For shapes that differ.
    """
    q, qd, qdd, tau = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (q, qd, qdd, tau))
    theta = np.asarray(theta, dtype=np.float64).reshape(-1)
    p = model.n_parameters
    if not q.shape == qd.shape == qdd.shape == tau.shape or q.ndim != 2:
        raise ValueError(f'q, qd, qdd and tau must have one shape (N, n), got {q.shape}, '
                         f'{qd.shape}, {qdd.shape}, {tau.shape}')
    if theta.shape != (p,):
        raise ValueError(f'theta must have {p} values, got {theta.shape}')
    count, n = q.shape
    dof = count - p / n  # none left: the noise is unknown, so is every σ (∞)
    uppers = [np.zeros((0, p)) for _ in range(n)]
    squares = np.zeros(n)
    for start in range(0, count, _BLOCK):
        part = slice(start, start + _BLOCK)
        w = model.regressor(q[part], qd[part], qdd[part])
        squares += np.sum((w @ theta - tau[part]) ** 2, axis=0)
        uppers = [_upper(np.vstack([uppers[j], w[:, j, :]])) for j in range(n)]
    scale = np.ones(n) if weights is None else np.asarray(weights, np.float64).reshape(n)
    uppers = [w * upper for w, upper in zip(scale, uppers)]
    stacked = _upper(np.vstack(uppers))
    _, s, vt = np.linalg.svd(np.vstack([stacked, np.zeros((p - stacked.shape[0], p))]))
    kept = s > RANK_TOLERANCE * s[0] if s[0] > 0 else np.zeros(s.size, dtype=bool)
    v = vt[kept].T
    inverse_gram = (v / s[kept] ** 2) @ v.T                      # (WᵀW)⁺
    variance = squares / max(dof, 1.0)
    middle = sum(variance[j] * scale[j] ** 2 * (upper.T @ upper)  # the uppers hold w_j²
                 for j, upper in enumerate(uppers))
    std = np.sqrt(np.maximum(np.diag(inverse_gram @ middle @ inverse_gram), 0.0))
    if not dof > 0:
        std[:] = np.inf
    null = vt[~kept].T
    if null.size:
        std[np.linalg.norm(null, axis=1) > 1e-6] = np.inf
    condition = float(s[0] / s[-1]) if s[-1] > 0 else float('inf')
    found = tuple(names) or tuple(getattr(model, 'parameter_names', ()))
    if len(found) != p:
        found = tuple(f'theta[{k}]' for k in range(p))
    return ParameterUncertainty(found, theta.copy(), std, condition)


def condition_number(model: LinearInParameters, q: ArrayLike, qd: ArrayLike,
                     qdd: ArrayLike) -> float:
    """s_max / s_min of the regressor of these states stacked, (N·n × p); ∞ if singular.

    Parameters
    ----------
    model : LinearInParameters
        τ = Y(q, q', q'') θ.
    q, qd, qdd : array_like of shape (N, n)
        Joint positions, velocities and accelerations (SI).
    """
    q, qd, qdd = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (q, qd, qdd))
    p = model.n_parameters
    upper = np.zeros((0, p))
    for start in range(0, q.shape[0], _BLOCK):
        part = slice(start, start + _BLOCK)
        w = model.regressor(q[part], qd[part], qdd[part]).reshape(-1, p)
        upper = _upper(np.vstack([upper, w]))
    s = np.linalg.svd(upper, compute_uv=False)
    return float(s[0] / s[-1]) if s.size == p and s[-1] > 0 else float('inf')


def _upper(rows: FloatArray) -> FloatArray:
    """R of the QR factorisation of ``rows`` (at most as many rows as columns)."""
    return cast(FloatArray, np.linalg.qr(rows, mode='r'))
