"""Batch least squares of any model linear in its parameters, τ = Y(q, q', q'') θ.

The one batch fit of the package's physical models: the SCARA's analytic 14-parameter
regressor (:class:`~scara_ident_ros.dynamics.regressor.LeastSquaresIdentifier`) and the
Pinocchio model of any URDF robot (:class:`~scara_ident_ros.dynamics.physical_model.
PhysicalModel`). Its online counterpart is :mod:`~scara_ident_ros.dynamics.
recursive_least_squares`, on the same :class:`LinearInParameters` protocol.

The stacked system (N·n × p) is never formed whole: it is reduced block by block, each
block's rows [Y | τ] stacked under the triangular factor so far and factored again by QR
(``R`` of [R; rows]), so memory is bounded by the block, and the normal equations (whose
conditioning is the square of the regressor's) are never formed.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ['BlockLeastSquares', 'LeastSquaresFit', 'LinearInParameters', 'RESIDUAL_WEIGHTS',
           'WEIGHT_FLOOR', 'fit_least_squares', 'residual_weights']

FloatArray = NDArray[np.float64]
#: ``fit_least_squares(weights=...)``: each joint weighted by 1/its residual RMS.
RESIDUAL_WEIGHTS = 'residual'
#: A joint's residual RMS counts as at least this share of the largest joint's when it is
#: weighted by it: one joint fitted almost exactly must not take every other's weight.
WEIGHT_FLOOR = 1e-3


class LinearInParameters(Protocol):
    """A model τ = Y(q, q', q'') θ."""

    @property
    def n_parameters(self) -> int:
        """Length p of θ."""
        ...

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """Y of shape (N, n, p) for states of shape (N, n)."""
        ...


class LeastSquaresFit(NamedTuple):
    """θ minimising Σ_j w_j² ||Y_j θ − τ_j||², and how well it fits.

    Attributes
    ----------
    theta : ndarray of shape (p,)
        The parameters.
    residual_rms : ndarray of shape (n,)
        Root-mean-square residual τ − Y θ per joint on the fitted samples (N·m, N).
    weights : ndarray of shape (n,)
        The weight of each joint's rows in the fit (all 1: unweighted).
    """

    theta: FloatArray
    residual_rms: FloatArray
    weights: FloatArray


class BlockLeastSquares:
    """min ||H θ − y||² over rows given block by block, by QR of [R | Qᵀy] (module docstring).

    Parameters
    ----------
    n_parameters : int
        Columns p of H.
    """

    def __init__(self, n_parameters: int) -> None:
        self._p = n_parameters
        self._upper = np.zeros((0, n_parameters + 1))
        self.rows = 0

    def add(self, rows: ArrayLike, values: ArrayLike) -> None:
        """Take rows H (m, p) and their values y (m,) (any shape of m values)."""
        h = np.asarray(rows, dtype=np.float64).reshape(-1, self._p)
        y = np.asarray(values, dtype=np.float64).reshape(-1, 1)
        if y.shape[0] != h.shape[0]:
            raise ValueError(f'{h.shape[0]} rows but {y.shape[0]} values')
        stacked = np.vstack([self._upper, np.hstack([h, y])])
        self._upper = cast(FloatArray, np.linalg.qr(stacked, mode='r'))
        self.rows += h.shape[0]

    @property
    def upper(self) -> FloatArray:
        """[R | Qᵀy] (k, p + 1), k ≤ p + 1: ||H θ − y||² = ||R θ − Qᵀy||² + a constant."""
        return self._upper.copy()

    @classmethod
    def stack(cls, systems: Sequence[BlockLeastSquares], weights: ArrayLike
              ) -> BlockLeastSquares:
        """The system of every row of ``systems``, those of system j times ``weights[j]``."""
        if not systems:
            raise ValueError('nothing to stack')
        scale = np.asarray(weights, dtype=np.float64).reshape(-1)
        stacked = cls(systems[0]._p)
        stacked.add_reduced(np.vstack([w * s._upper for w, s in zip(scale, systems)]),
                            sum(s.rows for s in systems))
        return stacked

    def add_reduced(self, upper: ArrayLike, rows: int) -> None:
        """Take [R | Qᵀy] of other rows (k, p + 1) that stand for ``rows`` rows."""
        stacked = np.vstack([self._upper, np.asarray(upper, dtype=np.float64)])
        self._upper = cast(FloatArray, np.linalg.qr(stacked, mode='r'))
        self.rows += rows

    def residual_norm(self, theta: ArrayLike) -> float:
        """||H θ − y|| over every row taken (the factor keeps the norm of [H | y] v)."""
        v = np.append(np.asarray(theta, dtype=np.float64).reshape(-1), -1.0)
        return float(np.linalg.norm(self._upper @ v))

    def solve(self) -> FloatArray:
        """θ of shape (p,) (minimum norm if the rows do not determine it).

        Raises
        ------
        ValueError
            With fewer rows than parameters.
        """
        p = self._p
        if self.rows < p:
            raise ValueError(f'{self.rows} equations cannot determine {p} parameters')
        solution, *_ = np.linalg.lstsq(self._upper[:p, :p], self._upper[:p, p], rcond=None)
        return np.asarray(solution, dtype=np.float64)


def fit_least_squares(model: LinearInParameters, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
                      tau: ArrayLike, *, block: int = 2048,
                      solve: Callable[[BlockLeastSquares], FloatArray] | None = None,
                      weights: ArrayLike | str | None = None) -> LeastSquaresFit:
    """Fit θ to every sample (module docstring).

    Parameters
    ----------
    q, qd, qdd : array_like of shape (N, n)
        Joint positions, velocities and accelerations (SI).
    tau : array_like of shape (N, n)
        Measured efforts (N·m, N).
    block : int
        Samples per block.
    solve : callable, optional
        θ of the reduced system (default :meth:`BlockLeastSquares.solve`): e.g. a fit under
        constraints (:mod:`~scara_ident_ros.dynamics.consistent_parameters`).
    weights : array_like of shape (n,) or 'residual', optional
        A weight w_j per joint: min Σ_j w_j² ||Y_j θ − τ_j||² (weighted least squares).
        ``'residual'`` (:data:`RESIDUAL_WEIGHTS`): w_j = 1/σ_j, σ_j joint j's residual RMS
        after an unweighted fit (at least :data:`WEIGHT_FLOOR` of the largest), so that each
        joint counts by its noise and not by the size of its efforts (Gautier & Poignet
        2001). Default: 1 for every joint. Each joint's rows are reduced apart once, so a
        weighting costs no second pass over the samples.

    Raises
    ------
    ValueError
        If the arrays' shapes differ or there are fewer equations than parameters.
    """
    q, qd, qdd, tau = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (q, qd, qdd, tau))
    if not q.shape == qd.shape == qdd.shape or q.ndim != 2:
        raise ValueError(f'q, qd, qdd must have one shape (N, n), got {q.shape}, {qd.shape}, '
                         f'{qdd.shape}')
    if tau.shape != q.shape:
        raise ValueError(f'tau must have shape {q.shape} (N, n), got {tau.shape}')
    p = model.n_parameters
    if tau.size < p:
        raise ValueError(f'{q.shape[0]} samples of {q.shape[1]} joints cannot determine '
                         f'{p} parameters')
    n = q.shape[1]
    if isinstance(weights, str):
        if weights != RESIDUAL_WEIGHTS:
            raise ValueError(f'weights must be values or {RESIDUAL_WEIGHTS!r}, got {weights!r}')
    elif weights is not None:
        scale = np.asarray(weights, dtype=np.float64).reshape(-1)
        if scale.shape != (n,) or not np.all(np.isfinite(scale) & (scale > 0.0)):
            raise ValueError(f'weights must be {n} positive finite values, got {weights}')
    joints = [BlockLeastSquares(p) for _ in range(n)]  # each joint's rows reduced apart
    for start in range(0, q.shape[0], block):
        part = slice(start, start + block)
        rows = model.regressor(q[part], qd[part], qdd[part])
        for j, system in enumerate(joints):
            system.add(rows[:, j, :], tau[part, j])

    if weights == RESIDUAL_WEIGHTS:
        scale = residual_weights(joints, q.shape[0])
    elif weights is None:
        scale = np.ones(n)
    stacked = BlockLeastSquares.stack(joints, scale)
    theta = stacked.solve() if solve is None else solve(stacked)
    residual = np.array([system.residual_norm(theta) for system in joints])
    return LeastSquaresFit(theta, np.asarray(residual / np.sqrt(q.shape[0]), dtype=np.float64),
                           scale)


def residual_weights(joints: Sequence[BlockLeastSquares], samples: int) -> FloatArray:
    """1/σ_j per joint, σ_j joint j's residual RMS after an unweighted fit of every joint's
    rows together (``joints[j]``: joint j's system of ``samples`` rows), at least
    :data:`WEIGHT_FLOOR` of the largest σ; shape (n,)."""
    theta = BlockLeastSquares.stack(joints, np.ones(len(joints))).solve()
    rms = np.array([system.residual_norm(theta) for system in joints]) / np.sqrt(samples)
    return np.asarray(1.0 / np.maximum(rms, WEIGHT_FLOOR * max(rms.max(), 1e-300)),
                      dtype=np.float64)
