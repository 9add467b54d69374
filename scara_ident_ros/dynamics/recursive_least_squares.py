"""Recursive least squares on the SCARA's regressor: the online model-based reference.

The same linear-in-parameters model as :class:`LeastSquaresIdentifier`, τ = Y(q, q', q'') θ,
updated as samples arrive, so that after any number of samples θ is the least-squares fit
of all of them (up to the prior ``P0 = p0 · I``). It is the online counterpart of the batch
fit: what an identifier that knew the robot's structure would reach on the same stream.

RLS without forgetting is kept in information form: ``A = P0⁻¹ + Σ YᵀY`` (14 × 14) and
``b = Σ Yᵀτ``, θ = A⁻¹ b after each update. It gives the covariance-form recursion's θ
(``P = A⁻¹``) at O(14²) per sample instead of a (4k × 4k) solve per block of k samples.
Samples may come one at a time or in blocks: the result is the same.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.dynamics.regressor import _DEFAULT_EPS, N_PARAMETERS, regressor

__all__ = ['RecursiveLeastSquares']


class RecursiveLeastSquares:
    """θ of τ = Y θ by recursive least squares.

    Parameters
    ----------
    p0 : float
        Prior covariance ``P0 = p0 · I`` of θ (a weak prior: large).
    coulomb_eps : float, optional
        Velocity scale of the Coulomb smooth sign (rad/s, m/s), as in the model.

    Attributes
    ----------
    theta : ndarray of shape (14,)
        Current estimate of the base parameters (starts at 0).
    count : int
        Samples taken so far.
    """

    def __init__(self, *, p0: float = 1e6, coulomb_eps: float = _DEFAULT_EPS) -> None:
        self.theta: NDArray[np.floating] = np.zeros(N_PARAMETERS)
        self._a = np.eye(N_PARAMETERS) / p0  # information matrix P⁻¹
        self._b = np.zeros(N_PARAMETERS)
        self.coulomb_eps = coulomb_eps
        self.count = 0

    def update(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, tau: ArrayLike) -> None:
        """Take a block of samples.

        Parameters
        ----------
        q, qd, qdd : array_like of shape (k, 4)
            Joint positions, velocities and accelerations (SI).
        tau : array_like of shape (k, 4)
            Measured efforts (N·m, N).
        """
        h = regressor(np.atleast_2d(q), np.atleast_2d(qd), np.atleast_2d(qdd),
                      coulomb_eps=self.coulomb_eps).reshape(-1, N_PARAMETERS)  # (4k, 14)
        y = np.asarray(tau, dtype=float).reshape(-1)
        self._a += h.T @ h
        self._b += h.T @ y
        self.theta = np.linalg.solve(self._a, self._b)
        self.count += int(np.atleast_2d(q).shape[0])

    def predict(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Efforts Y θ of shape (N, 4) for states of shape (N, 4)."""
        return regressor(q, qd, qdd, coulomb_eps=self.coulomb_eps) @ self.theta
