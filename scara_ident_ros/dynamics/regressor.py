"""Linear-in-parameters form of the SCARA dynamics, τ = Y(q, q', q'') θ, and its LS fit.

The inverse dynamics of :mod:`scara_ident_ros.dynamics.model` is linear in 14 base
parameters (the minimal set that the joint efforts determine):

==========  =====================================================  ========
name        definition                                             unit
==========  =====================================================  ========
``zz1r``    izz1 + m1 lc1² + (m2 + m3 + m4) l1²                    kg·m²
``zz2r``    izz2 + izz3 + izz4 + m2 lc2² + (m3 + m4) l2²           kg·m²
``mx2r``    l1 (m2 lc2 + (m3 + m4) l2)                             kg·m²
``m34``     m3 + m4                                                kg
``zz4``     izz4                                                   kg·m²
``w34``     (m3 + m4) g, the quill's weight                        N
``fv1..4``  viscous friction                                       SI
``fc1..4``  Coulomb friction (with tanh(q'/eps) as sign)           N·m, N
==========  =====================================================  ========

The weight is kept as its own parameter so that the regressor needs no physical constant;
only the Coulomb smoothing velocity ``coulomb_eps`` shapes it. The individual masses,
inertias and centre-of-mass distances are not identifiable from joint efforts alone.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from scara_ident_ros.dynamics.least_squares import fit_least_squares
from scara_ident_ros.dynamics.model import _as_states
from scara_ident_ros.dynamics.params import N_JOINTS, ScaraParams

__all__ = ['PARAMETER_NAMES', 'N_PARAMETERS', 'regressor', 'base_parameters',
           'LeastSquaresIdentifier', 'ScaraRegressor']

#: Names of the base parameters θ, in order.
PARAMETER_NAMES: tuple[str, ...] = (
    ('zz1r', 'zz2r', 'mx2r', 'm34', 'zz4', 'w34')
    + tuple(f'fv{i + 1}' for i in range(N_JOINTS))
    + tuple(f'fc{i + 1}' for i in range(N_JOINTS)))
N_PARAMETERS = len(PARAMETER_NAMES)

_DEFAULT_EPS: float = ScaraParams().coulomb_eps


def regressor(q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, *,
              coulomb_eps: float = _DEFAULT_EPS) -> np.ndarray:
    """Regressor matrix Y with τ = Y θ for the base parameters :data:`PARAMETER_NAMES`.

    Parameters
    ----------
    q, qd, qdd : array_like of shape (4,) or (N, 4)
        Joint positions, velocities and accelerations (SI).
    coulomb_eps : float, optional
        Velocity scale of the Coulomb smooth sign tanh(q' / eps) (rad/s, m/s); must match the
        model's ``ScaraParams.coulomb_eps``.

    Returns
    -------
    ndarray of shape (4, 14) or (N, 4, 14)
        Row j maps θ to the effort of joint j.
    """
    if not coulomb_eps > 0.0:
        raise ValueError(f'coulomb_eps must be > 0, got {coulomb_eps!r}')
    (q, qd, qdd), single = _as_states(q, qd, qdd)
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    v1, v2 = qd[:, 0], qd[:, 1]
    a1, a2, a3, a4 = qdd.T
    out = np.zeros((q.shape[0], N_JOINTS, N_PARAMETERS))
    # zz1r, zz2r, mx2r, m34, zz4, w34
    out[:, 0, 0] = a1
    out[:, 0, 1] = a1 + a2
    out[:, 0, 2] = c2 * (2.0 * a1 + a2) - s2 * v2 * (2.0 * v1 + v2)
    out[:, 0, 4] = -a4
    out[:, 1, 1] = a1 + a2
    out[:, 1, 2] = c2 * a1 + s2 * v1 ** 2
    out[:, 1, 4] = -a4
    out[:, 2, 3] = a3
    out[:, 2, 5] = -1.0
    out[:, 3, 4] = a4 - a1 - a2
    joints = np.arange(N_JOINTS)
    out[:, joints, 6 + joints] = qd
    out[:, joints, 6 + N_JOINTS + joints] = np.tanh(qd / coulomb_eps)
    return out[0] if single else out


def base_parameters(params: ScaraParams) -> np.ndarray:
    """Base parameters θ (14,) of a physical parameter set, in the order and units of
    :data:`PARAMETER_NAMES`."""
    p = params
    m34 = p.m3 + p.m4
    inertial = [p.izz1 + p.m1 * p.lc1 ** 2 + (p.m2 + m34) * p.l1 ** 2,
                p.izz2 + p.izz3 + p.izz4 + p.m2 * p.lc2 ** 2 + m34 * p.l2 ** 2,
                p.l1 * (p.m2 * p.lc2 + m34 * p.l2),
                m34,
                p.izz4,
                m34 * p.gravity]
    return np.concatenate([inertial, p.viscous, p.coulomb])


class ScaraRegressor:
    """:func:`regressor` as a model of the ``LinearInParameters`` protocol
    (:mod:`~scara_ident_ros.dynamics.least_squares`).

    Parameters
    ----------
    coulomb_eps : float, optional
        Velocity scale of the Coulomb smooth sign (rad/s, m/s), as in the model.
    """

    n_parameters = N_PARAMETERS

    def __init__(self, *, coulomb_eps: float = _DEFAULT_EPS) -> None:
        self.coulomb_eps = coulomb_eps

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> np.ndarray:
        """Y of shape (N, 4, 14) or (4, 14) (see :func:`regressor`)."""
        return regressor(q, qd, qdd, coulomb_eps=self.coulomb_eps)


class LeastSquaresIdentifier:
    """Model-based identification: θ by linear least squares on the stacked regressor.

    Parameters
    ----------
    coulomb_eps : float, optional
        Velocity scale of the Coulomb smooth sign (rad/s, m/s).

    Attributes
    ----------
    theta_ : ndarray of shape (14,)
        Identified base parameters after :meth:`fit`.
    residual_rms_ : ndarray of shape (4,)
        Root-mean-square effort residual per joint on the training data (N·m, N).
    """

    def __init__(self, *, coulomb_eps: float = _DEFAULT_EPS) -> None:
        self.coulomb_eps = coulomb_eps
        self.theta_: np.ndarray | None = None
        self.residual_rms_: np.ndarray | None = None

    def fit(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
            tau: np.ndarray) -> LeastSquaresIdentifier:
        """Estimate θ minimising Σ ||Y θ − τ||² over the samples: q, qd, qdd (N, 4) in SI
        and measured efforts ``tau`` (N, 4) (N·m, N); return ``self``."""
        fit = fit_least_squares(ScaraRegressor(coulomb_eps=self.coulomb_eps), q, qd, qdd, tau)
        self.theta_, self.residual_rms_ = fit.theta, fit.residual_rms
        return self

    def predict(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Predicted efforts Y θ (N·m, N·m, N, N·m) for q, qd, qdd of shape (4,) or (N, 4)
        (SI), in the same shape."""
        if self.theta_ is None:
            raise RuntimeError('LeastSquaresIdentifier.predict called before fit')
        return regressor(q, qd, qdd, coulomb_eps=self.coulomb_eps) @ self.theta_
