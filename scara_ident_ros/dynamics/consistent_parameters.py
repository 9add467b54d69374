"""Physically consistent parameters of a physical model: a fit under the pseudo-inertia LMI.

Least squares identifies the base parameters θ_b of a robot, combinations of the 10
inertial parameters of each body (:mod:`~scara_ident_ros.dynamics.base_reduction`); on real
data (noise, friction the law does not hold, joints that barely move) it often returns base
parameters that no set of bodies has: negative masses, inertias that break the triangle
inequalities. Such a model predicts well where it was fitted and badly elsewhere, and it
cannot be written back to a URDF.

A body's 10 parameters (m, h = m·c, and the rotational inertia I about its joint frame)
are those of a real mass distribution if and only if its *pseudo-inertia*

    J = [[Σ, h], [hᵀ, m]],    Σ = ½ tr(I) 1 − I   (the second moments ∫ r rᵀ dm),

is positive semidefinite (Wensing, Kim and Slotine, "Linear matrix inequalities for
physically consistent inertial parameter identification", IEEE RA-L 2017). J ⪰ 0 implies
m ≥ 0 and the triangle inequalities of I's principal moments; J ⪰ ε·1 with a small ε keeps
every mass positive. So the consistent fit is a semidefinite program in the standard
parameters θ_s (one 4×4 LMI per body, rotor inertias and viscous and Coulomb friction ≥ 0):

    min ||R (φ(θ_s, f) − φ_LS)||² + λ ||θ_s − θ_prior||²,    φ = [K θ_s, f],

where R is the triangular factor of the stacked regressor (so the first term is the
training residual's increase over least squares: the fit stays as close to the least-squares
fit of the base parameters as the data can tell), K maps standard to base parameters, and
the small λ (``PRIOR_WEIGHT`` relative to R's scale) only chooses, among the standard
parameters of the fitted base parameters, those nearest the URDF's own (the directions
the data cannot see). It is solved with cvxpy and the Clarabel interior-point solver (SCS
if Clarabel fails).

Public API::

    PRIOR_WEIGHT, MIN_EIGENVALUE
    pseudo_inertia(parameters) -> (4, 4)
    consistency_report(parameters) -> dict
    consistent_fit(model, upper, *, prior=None) -> ConsistentFit
"""
from __future__ import annotations

from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.dynamics.base_reduction import BaseReduction
from scara_ident_ros.errors import ScaraIdentError

__all__ = ['ConsistentFit', 'MIN_EIGENVALUE', 'PRIOR_WEIGHT', 'ReducedModel', 'consistency_report',
           'consistent_fit', 'pseudo_inertia']

FloatArray = NDArray[np.float64]
#: λ of the pull towards the prior, relative to the mean of diag(RᵀR) (R's scale).
PRIOR_WEIGHT = 1e-6
#: ε of J ⪰ ε·1 (kg·m², kg): every mass and second moment stays positive.
MIN_EIGENVALUE = 1e-6


class ConsistentFit(NamedTuple):
    """The consistent fit's parameters.

    Attributes
    ----------
    standard : ndarray of shape (P,)
        Standard parameters (the model's ``standard_names``: 10 per body, then rotor
        inertias), physically consistent.
    theta : ndarray of shape (n_parameters,)
        The model's θ: their base parameters, then the friction coefficients and offsets.
    solver : str
        The cvxpy solver that solved it.
    """

    standard: FloatArray
    theta: FloatArray
    solver: str


def pseudo_inertia(parameters: ArrayLike) -> FloatArray:
    """The 4×4 pseudo-inertia J of a body's 10 parameters.

    Parameters
    ----------
    parameters : array_like of shape (10,)
        (m, m·c_x, m·c_y, m·c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz), SI, the inertia about
        the body's joint frame (Pinocchio's ``toDynamicParameters`` order).

    Returns
    -------
    ndarray of shape (4, 4)
        [[½ tr(I) 1 − I, h], [hᵀ, m]] (kg·m², kg·m, kg).
    """
    m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = np.asarray(parameters, dtype=np.float64)
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    out = np.zeros((4, 4))
    out[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    out[:3, 3] = out[3, :3] = (hx, hy, hz)
    out[3, 3] = m
    return out


def consistency_report(parameters: ArrayLike) -> dict[str, float]:
    """How far a body's 10 parameters are from a real body (positive figures: consistent).

    Returns
    -------
    dict
        ``mass`` (kg); ``pseudo_inertia`` the smallest eigenvalue of J; ``triangle`` the
        smallest of I_1 + I_2 − I_3 over the principal moments about the centre of mass
        (and ``principal`` the smallest moment), kg·m².
    """
    p = np.asarray(parameters, dtype=np.float64)
    m = float(p[0])
    j = pseudo_inertia(p)
    inertia = np.trace(j[:3, :3]) * np.eye(3) - j[:3, :3]
    com = p[1:4] / m if m > 0.0 else np.zeros(3)
    central = inertia - m * (np.dot(com, com) * np.eye(3) - np.outer(com, com))
    moments = np.linalg.eigvalsh(central)
    return {'mass': m, 'pseudo_inertia': float(np.linalg.eigvalsh(j)[0]),
            'principal': float(moments[0]),
            'triangle': float(min(moments[0] + moments[1] - moments[2],
                                  moments[0] + moments[2] - moments[1],
                                  moments[1] + moments[2] - moments[0]))}


class ReducedModel(Protocol):
    """What :func:`consistent_fit` needs of a physical model
    (:class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel` has it): its sizes, the
    base reduction, which θ entries are friction, the URDF's standard parameters."""

    @property
    def n_parameters(self) -> int: ...
    @property
    def n_base(self) -> int: ...
    @property
    def n_joints(self) -> int: ...
    @property
    def n_bodies(self) -> int: ...
    @property
    def reduction(self) -> BaseReduction: ...
    @property
    def asymmetric(self) -> bool: ...
    @property
    def stribeck_velocity(self) -> float: ...
    @property
    def source(self) -> str: ...

    def urdf_standard_parameters(self) -> NDArray[np.float64]: ...


def consistent_fit(model: ReducedModel, upper: ArrayLike, *,
                   prior: ArrayLike | None = None) -> ConsistentFit:
    """Solve the module docstring's semidefinite program.

    Parameters
    ----------
    model : ReducedModel
        A physical model: gives the base reduction K, the bodies and which θ entries are friction.
    upper : array_like of shape (k, p + 1)
        [R | Qᵀτ] of the stacked system (``BlockLeastSquares.upper``), k ≤ p + 1 rows; or,
        to find consistent parameters near given base parameters θ (p,) alone, the rows
        [1 | θ] (``np.hstack([np.eye(p), θ[:, None]])``).
    prior : array_like of shape (P,), optional
        Standard parameters to stay near where the data do not decide (default the URDF's).

    Raises
    ------
    ScaraIdentError
        If cvxpy is missing or no solver finds a solution.
    """
    try:
        import cvxpy
    except ImportError as exc:
        raise ScaraIdentError(f'the consistent fit needs cvxpy (pip install cvxpy clarabel): '
                              f'{exc}') from None
    cp: Any = cvxpy  # its stubs lack most of the modelling functions
    u = np.asarray(upper, dtype=np.float64)
    p, nb, n = model.n_parameters, model.n_base, model.n_joints
    if u.ndim != 2 or u.shape[1] != p + 1:
        raise ValueError(f'upper must have {p + 1} columns [R | Q^T tau], got {u.shape}')
    r, z = u[:, :p], u[:, p]
    reduction = model.reduction
    size = len(reduction.names)
    k_matrix = np.zeros((nb, size))
    k_matrix[np.arange(nb), reduction.independent] = 1.0
    k_matrix[:, reduction.dependent] = reduction.beta
    theta_prior = (model.urdf_standard_parameters() if prior is None
                   else np.asarray(prior, dtype=np.float64))
    scale = float(np.mean(np.sum(r ** 2, axis=0))) or 1.0
    r, z = r / np.sqrt(scale), z / np.sqrt(scale)  # the objective of order 1
    bodies = model.n_bodies
    pseudo = [cp.Variable((4, 4), symmetric=True) for _ in range(bodies)]
    parts: list[Any] = []
    for j in pseudo:
        trace = j[0, 0] + j[1, 1] + j[2, 2]
        parts += [j[3, 3], j[0, 3], j[1, 3], j[2, 3], trace - j[0, 0], -j[0, 1],
                  trace - j[1, 1], -j[0, 2], -j[1, 2], trace - j[2, 2]]
    constraints = [j >> MIN_EIGENVALUE * np.eye(4) for j in pseudo]
    rotor = size - 10 * bodies
    if rotor:
        armature = cp.Variable(rotor)
        parts.append(armature)
        constraints.append(armature >= 0.0)
    standard = cp.hstack(parts)
    friction = cp.Variable(p - nb)
    viscous, coulomb = friction[:n], friction[n:2 * n]
    constraints += [viscous >= 0.0, coulomb >= 0.0]
    if model.asymmetric:
        start = (3 if model.stribeck_velocity > 0.0 else 2) * n
        asymmetric = friction[start:start + n]
        constraints += [coulomb - asymmetric >= 0.0, coulomb + asymmetric >= 0.0]
    phi = cp.hstack([k_matrix @ standard, friction])
    weight = PRIOR_WEIGHT
    squares = cp.sum_squares
    objective = cp.Minimize(squares(r @ phi - z) + weight * squares(standard - theta_prior))
    problem = cp.Problem(objective, constraints)
    for solver in ('CLARABEL', 'SCS'):
        try:
            problem.solve(solver=solver)
        except (cp.error.SolverError, ValueError):
            continue
        if problem.status in ('optimal', 'optimal_inaccurate') and standard.value is not None:
            value = np.asarray(standard.value, dtype=np.float64)
            theta = np.concatenate([k_matrix @ value,
                                    np.asarray(friction.value, dtype=np.float64)])
            return ConsistentFit(value, theta, solver)
    raise ScaraIdentError(f'{model.source}: no physically consistent parameters found '
                          f'(cvxpy status {problem.status})')
