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

from collections.abc import Callable
from typing import NamedTuple, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ['BlockLeastSquares', 'LeastSquaresFit', 'LinearInParameters', 'fit_least_squares']

FloatArray = NDArray[np.float64]


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
    """θ minimising Σ ||Y θ − τ||², and how well it fits.

    Attributes
    ----------
    theta : ndarray of shape (p,)
        The parameters.
    residual_rms : ndarray of shape (n,)
        Root-mean-square residual τ − Y θ per joint on the fitted samples (N·m, N).
    """

    theta: FloatArray
    residual_rms: FloatArray


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
                      ) -> LeastSquaresFit:
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
    system = BlockLeastSquares(p)
    for start in range(0, q.shape[0], block):
        part = slice(start, start + block)
        system.add(model.regressor(q[part], qd[part], qdd[part]), tau[part])
    theta = system.solve() if solve is None else solve(system)
    squares = np.zeros(q.shape[1])
    for start in range(0, q.shape[0], block):
        part = slice(start, start + block)
        error = model.regressor(q[part], qd[part], qdd[part]) @ theta - tau[part]
        squares += np.sum(error ** 2, axis=0)
    return LeastSquaresFit(theta, np.asarray(np.sqrt(squares / q.shape[0]), dtype=np.float64))
