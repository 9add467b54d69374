"""Recursive least squares on a linear-in-parameters model: the online model-based identifier.

A model τ = Y(q, q', q'') θ (the SCARA's analytic 14-parameter regressor by default, or a
:class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel` of any URDF robot: any
:class:`~scara_ident_ros.dynamics.least_squares.LinearInParameters`), updated
as samples arrive, so that after any number of samples θ is the least-squares fit of all of
them (up to the prior θ ~ (θ0, p0 · I)). It is the online counterpart of the batch fit
(:func:`~scara_ident_ros.dynamics.least_squares.fit_least_squares`): what
an identifier that knows the robot's structure reaches on the same stream.

RLS without forgetting is kept in information form: ``A = P0⁻¹ + Σ YᵀY`` (p × p) and
``b = P0⁻¹ θ0 + Σ Yᵀτ``, θ = A⁻¹ b after each update. It gives the covariance-form
recursion's θ (``P = A⁻¹``) at O(p²) per sample plus one p × p solve per update, instead of
a (n·k × n·k) solve per block of k samples. Samples may come one at a time or in blocks: the
result is the same.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.dynamics.least_squares import LinearInParameters
from scara_ident_ros.dynamics.regressor import _DEFAULT_EPS, ScaraRegressor

__all__ = ['RecursiveLeastSquares']


class RecursiveLeastSquares:
    """θ of τ = Y θ by recursive least squares.

    Parameters
    ----------
    model : LinearInParameters, optional
        The regressor; default the SCARA's analytic one with ``coulomb_eps``.
    p0 : float
        Prior covariance ``P0 = p0 · I`` of θ (a weak prior: large).
    theta0 : array_like of shape (p,), optional
        Prior mean of θ (e.g. an offline fit to go on from); default 0.
    coulomb_eps : float, optional
        Velocity scale of the SCARA regressor's Coulomb smooth sign (rad/s, m/s); only
        without ``model``.

    Attributes
    ----------
    theta : ndarray of shape (p,)
        Current estimate (starts at ``theta0``).
    count : int
        Samples taken so far.
    """

    def __init__(self, model: LinearInParameters | None = None, *, p0: float = 1e6,
                 theta0: ArrayLike | None = None,
                 coulomb_eps: float = _DEFAULT_EPS) -> None:
        if not p0 > 0.0:
            raise ValueError(f'p0 must be > 0, got {p0!r}')
        self.model: LinearInParameters = (ScaraRegressor(coulomb_eps=coulomb_eps)
                                          if model is None else model)
        p = self.model.n_parameters
        self.theta: NDArray[np.float64] = (np.zeros(p) if theta0 is None else
                                           np.array(theta0, dtype=np.float64).reshape(p))
        self._a = np.eye(p) / p0  # information matrix P⁻¹
        self._b = self._a @ self.theta
        self.count = 0

    @property
    def n_parameters(self) -> int:
        """Length p of θ."""
        return int(self.theta.shape[0])

    def update(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, tau: ArrayLike) -> None:
        """Take a block of samples: q, qd, qdd (k, n) in SI and efforts ``tau`` (k, n)."""
        h = self.model.regressor(np.atleast_2d(q), np.atleast_2d(qd), np.atleast_2d(qdd))
        self.update_rows(h.reshape(-1, self.n_parameters), tau,
                         samples=int(np.atleast_2d(q).shape[0]))

    def update_rows(self, h: ArrayLike, y: ArrayLike, *, samples: int = 1) -> None:
        """Take regressor rows directly: ``h`` (m, p) and efforts ``y`` (m,).

        ``samples`` is how many samples the rows are, for :attr:`count`.

        Raises
        ------
        ValueError
            If the rows or efforts are not finite (nothing is taken).
        """
        rows = np.asarray(h, dtype=np.float64).reshape(-1, self.n_parameters)
        values = np.asarray(y, dtype=np.float64).reshape(-1)
        if values.shape[0] != rows.shape[0]:
            raise ValueError(f'{rows.shape[0]} regressor rows but {values.shape[0]} efforts')
        if not (np.all(np.isfinite(rows)) and np.all(np.isfinite(values))):
            raise ValueError('regressor rows and efforts must be finite')
        self._a += rows.T @ rows
        self._b += rows.T @ values
        self.theta = np.asarray(np.linalg.solve(self._a, self._b), dtype=np.float64)
        self.count += samples

    def predict(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Efforts Y θ of shape (N, n) for states of shape (N, n)."""
        return self.model.regressor(q, qd, qdd) @ self.theta
