"""An excitation designed for identification: the Fourier motion that predicts other motion best.

Each joint j follows a Fourier series of L harmonics of base frequency f = 1/T about the
middle c_j of its range (:class:`~scara_ident_ros.sim.trajectory.FourierTrajectory`, with
velocity coefficients a_jk, b_jk and ω_k = 2π k f):

    q_j(t) = c_j + Σ_k (a_jk sin(ω_k t) − b_jk cos(ω_k t)) / ω_k

Its coefficients minimise, subject to the limits, the mean variance of the efforts the
identified model predicts along other motion, together with the condition number of the
physical model's regressor W (the URDF's base parameters with the friction and
rotor-inertia columns :class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel` fits)
stacked over a period (Swevers, Ganseman, Tükel, De Schutter and Van Brussel, "Optimal robot
excitation and identification", IEEE T-RA 1997, for the condition number; I-optimality,
Atkinson, Donev and Tobias, "Optimum experimental designs", 2007, for the variance):

    J = log tr(A (WᵀW)⁻¹) + λ log cond(W),    A = (1/N_r) Σ_j W_r,jᵀ W_r,j / var(τ_r,j),

λ = :data:`CONDITION_WEIGHT` (0.5).

With efforts of noise σ² on every joint, the least-squares θ̂ has covariance σ² (WᵀW)⁻¹, so
tr(A (WᵀW)⁻¹) is, up to the factor σ² n, the held-out NMSE (mean over the n joints) the
noise gives on average along a reference
motion W_r (N_r samples; W_r,j its rows of joint j, τ_r,j = W_r,j θ_URDF the efforts the
URDF's own parameters give, which scale each joint as the NMSE does): 60 s of the random
sequence of seed :data:`REFERENCE_SEED`, spread over the ranges as any other motion of the
arm. It prefers large motion (the efforts grow, their noise does not); the condition number
alone is lowered by shrinking the motion, and minimising it alone identified the physical
model worse than the random sequence of the same length (benchmarks/excitation_length.md).
How the two compare: that benchmark. q, q', q'' are linear in the coefficients, so the
limits on a grid of the period are linear inequalities: the position within
``position_fraction`` of each half-range about c_j, the speed and the acceleration within
their fractions of the limits (those of :data:`~scara_ident_ros.sim.sequence.
SEQUENCE_EXCITATION`, as the random sequence draws them: the approach into it and its stops
keep to :data:`~scara_ident_ros.sim.sequence.SEQUENCE_LIMITS`). scipy's SLSQP minimises J
from a seeded random start; its gradient is the chain rule

    ∂J/∂x = Σ_ij (G · ∂W/∂q_ij) ∂q_ij/∂x + (the same for q', q''),
    G = −2 W M A M / tr(A M) + λ (u_1 v_1ᵀ / s_1 − u_p v_pᵀ / s_p),    M = (WᵀW)⁻¹

(s_i, u_i, v_i the singular values and vectors of W), with ∂W/∂q_j, ∂W/∂q'_j, ∂W/∂q''_j by
forward differences (3n + 1 regressors of the grid per gradient, not one per coefficient).
The result is scaled down per joint, if need be, to keep to its fractions on a dense grid
(1,000 points per period of the highest harmonic). Given the arm's collision geometry
(:mod:`~scara_ident_ros.excitation.self_collision`), where links meet on a grid of the
period, the position bound of the joint whose narrowing parts the most of them is narrowed
(by :data:`COLLISION_SHRINK` at a time, about the middle of its range) until they are
apart, and the optimisation starts again within the narrowed bounds (up to
:data:`NARROWING_ROUNDS` times, half the time left each); whatever still collides then is
shrunk whole towards the middle of the ranges. A check of the optimiser's results, not a
constraint of its steps (one check costs 0.1-0.3 s for the UR5 and the Panda, too much for
every step).

:class:`OptimizedExcitation` repeats the motion every period: an
:class:`~scara_ident_ros.excitation.plan.ExcitationPlan` approaches it from rest as it
approaches the random sequence, and stops it as it stops that. :func:`plan_condition` is
cond(W) over a plan's excitation, to compare plans of the same length.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from scara_ident_ros.dynamics.joint_limits import JointLimits, LimitsError
from scara_ident_ros.dynamics.least_squares import LinearInParameters
from scara_ident_ros.dynamics.parameter_uncertainty import condition_number
from scara_ident_ros.excitation.joint_sequence import JointSequence, Motion
from scara_ident_ros.excitation.plan import ExcitationPlan
from scara_ident_ros.excitation.self_collision import SelfCollision
from scara_ident_ros.sim.sequence import SEQUENCE_EXCITATION
from scara_ident_ros.sim.trajectory import FourierTrajectory

__all__ = ['COLLISION_PER_HARMONIC', 'COLLISION_SHRINK', 'CONDITION_WEIGHT', 'DEFAULT_HARMONICS',
           'DEFAULT_PERIOD',
           'NARROWING_ROUNDS', 'REFERENCE_SEED', 'OptimizedExcitation', 'optimize_excitation',
           'plan_condition']

FloatArray = NDArray[np.float64]
#: Harmonics L per joint and base period T (s) of the optimised motion: up to 1 Hz, as the
#: random sequence's (benchmarks/excitation_length.md).
DEFAULT_HARMONICS = 10
DEFAULT_PERIOD = 10.0
_SAMPLES_PER_HARMONIC = 16   # regressor samples per period of the highest harmonic
_CHECKS_PER_HARMONIC = 10    # limit constraints per period of the highest harmonic
_DENSE_PER_HARMONIC = 1000   # points of the final check
#: Shrink factor of the amplitudes per collision found, and the grid checked (points per
#: period of the highest harmonic).
COLLISION_SHRINK = 0.8
COLLISION_PER_HARMONIC = 20
_COLLISION_TRIES = 20
#: Optimisations again within position bounds narrowed to keep the links apart, at most.
NARROWING_ROUNDS = 3
_STEP = 1e-6                 # relative step of the forward differences of W
#: λ, the weight of log cond(W) in the criterion: on the SCARA 0 left cond(W) at 0.4-0.65
#: of the random sequence's, 1 lost all the variance gained, 0.5 kept 0.77-0.83 of it and
#: cond(W) at 0.19-0.24 (seeds 1, 2; 16 s, 10 harmonics of 10 s; 2026-12-07).
CONDITION_WEIGHT = 0.5
_SINGULAR = 1e-12            # s_p / s_1 below which W counts as singular
_SINGULAR_VALUE = 1e3        # J of a singular W
#: Seed of the random sequence whose motion the criterion's prediction variance is taken
#: along (none of the benchmark's held-out seeds), and its length and sample period (s).
REFERENCE_SEED = 2 ** 20
_REFERENCE_SECONDS = 60.0
_REFERENCE_STEP = 0.05
_LEAST_VARIANCE = 1e-4       # floor of a joint's reference effort variance, of the largest


@dataclass(frozen=True)
class OptimizedExcitation:
    """The optimised periodic motion, as the plan takes a sequence.

    Attributes
    ----------
    trajectory : FourierTrajectory
        One period of the motion, repeated.
    start_condition, condition : float
        cond(W) on the optimiser's grid at the seeded start and at the result.
    iterations : int
        SLSQP iterations made.
    seconds : float
        Time the optimisation took (s).
    collision_scale : float or None
        The factor the motion's amplitudes were shrunk by, towards the middle of the
        ranges, to keep its links apart (1: not at all); None if not checked.
    narrowed : ndarray of shape (n,) or None
        The factors each joint's position bound was narrowed by, about the middle of its
        range, for the links to stay apart (1: not at all); None if not checked.
    """

    trajectory: FourierTrajectory
    start_condition: float
    condition: float
    iterations: int
    seconds: float
    collision_scale: float | None = None
    narrowed: FloatArray | None = None

    def collision_summary(self) -> str:
        """What keeping the links apart changed, in one line."""
        if self.narrowed is None or self.collision_scale is None:
            return 'self-collision not checked (no collision geometry)'
        return ('to keep the links apart: position bounds × '
                + ', '.join(f'{f:.2g}' for f in self.narrowed)
                + f' (per joint), amplitudes × {self.collision_scale:.2g}')

    def excitation(self, k: int) -> FourierTrajectory:
        """The motion of period k: always the same one."""
        return self.trajectory

    def evaluate(self, t: FloatArray) -> Motion:
        """q, q', q'' at times t (N,) >= 0 (s), each of shape (N, n)."""
        q, qd, qdd = self.trajectory.evaluate(np.atleast_1d(np.asarray(t, dtype=float)))
        return q, qd, qdd


class _OutOfTime(Exception):
    """The time budget is spent: the best point so far is the result."""


def optimize_excitation(model: LinearInParameters, limits: JointLimits, *, seed: int,
                        n_harmonics: int = DEFAULT_HARMONICS, period: float = DEFAULT_PERIOD,
                        max_seconds: float = 120.0, max_iterations: int = 200,
                        collision: SelfCollision | None = None) -> OptimizedExcitation:
    """The Fourier coefficients of least J (prediction variance along the reference and
    cond(W)) within the limits (module docstring).

    Parameters
    ----------
    model : LinearInParameters
        The model to identify (a ``PhysicalModel`` of the arm, whose ``urdf_parameters``
        weight the joints), for the joints of ``limits`` in their order.
    limits : JointLimits
        The limits with the safety margins taken off (what the motion keeps to).
    seed : int
        Seed of the random start (>= 0).
    n_harmonics : int
        L, >= 1.
    period : float
        T (s), > 0.
    max_seconds : float
        Time budget (s) of the optimisations: the best point found by then is the result
        (given ``collision``, the first gets half, each next one half of what is left).
    max_iterations : int
        SLSQP iterations at most.
    collision : SelfCollision, optional
        The arm's self-collision check on a grid of the period
        (:data:`COLLISION_PER_HARMONIC` points per period of the highest harmonic): where
        links meet, joints' position bounds are narrowed and the motion optimised again (up
        to :data:`NARROWING_ROUNDS` times); what still collides is shrunk towards the middle
        of the ranges (by :data:`COLLISION_SHRINK` at a time) until no point of the grid
        brings two links together.

    Raises
    ------
    LimitsError
        For settings out of range, or a motion that collides however much it is shrunk.
    """
    if isinstance(n_harmonics, bool) or not isinstance(n_harmonics, int) or n_harmonics < 1:
        raise LimitsError(f'n_harmonics must be an integer >= 1, got {n_harmonics!r}')
    if not (math.isfinite(period) and period > 0.0):
        raise LimitsError(f'period must be > 0 s, got {period!r}')
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise LimitsError(f'seed must be an integer >= 0, got {seed!r}')
    started = time.perf_counter()
    deadline = started + max_seconds
    problem = _Problem(model, limits, n_harmonics, period)
    x = problem.start(seed)
    start_condition = problem.condition(problem.trajectory(x))
    rounds = 0 if collision is None else NARROWING_ROUNDS
    x, iterations, finished = _minimise(
        problem, x, deadline - (max_seconds / 2 if rounds else 0.0), max_iterations)
    trajectory = problem.within_limits(problem.trajectory(x))
    narrowed = np.ones(problem.n)
    for round_ in range(rounds):
        assert collision is not None
        factors = _narrowing(trajectory, collision)
        if factors is None and finished:
            break
        if factors is not None:         # narrow, and start from the motion narrowed
            narrowed *= factors
            problem.narrow(factors)
            x = problem.trajectory_x(trajectory) * np.tile(np.repeat(factors, n_harmonics), 2)
        left = deadline - time.perf_counter()   # else: go on where the time ran out
        x, more, finished = _minimise(problem, x, deadline - (
            left / 2 if round_ < rounds - 1 else 0.0), max_iterations)
        iterations += more
        trajectory = problem.within_limits(problem.trajectory(x))
    scale = None if collision is None else _collision_free_scale(trajectory, collision)
    if scale is not None and scale < 1.0:
        trajectory = FourierTrajectory(trajectory.q0, trajectory.a * scale,
                                       trajectory.b * scale, trajectory.base_frequency_hz)
    return OptimizedExcitation(trajectory, start_condition, problem.condition(trajectory),
                               iterations, time.perf_counter() - started, scale,
                               None if collision is None else narrowed)


def _minimise(problem: _Problem, x0: FloatArray, deadline: float, max_iterations: int
              ) -> tuple[FloatArray, int, bool]:
    """SLSQP from the feasible x0 until ``deadline`` (perf_counter s): the best feasible
    point, the iterations made, and whether it stopped before the deadline."""
    best_x, best_value = [x0], [problem.objective(x0)]      # the best feasible point

    def objective(x: FloatArray) -> float:
        if time.perf_counter() > deadline:
            raise _OutOfTime
        value = problem.objective(x)
        if value < best_value[0] and problem.feasible(x):
            best_x[0], best_value[0] = x.copy(), value
        return value

    iterations = [0]

    def count(_: FloatArray) -> None:
        iterations[0] += 1

    try:
        scipy.optimize.minimize(
            objective, x0, jac=problem.gradient, method='SLSQP', callback=count,
            constraints=[{'type': 'ineq', 'fun': problem.slack,
                          'jac': lambda x: problem.constraint_matrix}],
            options={'maxiter': max_iterations, 'ftol': 1e-6})
    except _OutOfTime:
        return best_x[0], iterations[0], False
    return best_x[0], iterations[0], True


def _narrowing(trajectory: FourierTrajectory, collision: SelfCollision
               ) -> FloatArray | None:
    """Per joint, the factors (n,) (powers of COLLISION_SHRINK) of the excursions about the
    middle that keep the links apart on the grid, shrinking one joint at a time, the one
    that parts the most colliding points; None if they are apart already."""
    q, _, _ = trajectory.evaluate(trajectory.grid(COLLISION_PER_HARMONIC))
    centre = trajectory.q0
    hits = collision.colliding(q)
    if not np.any(hits):
        return None
    factors = np.ones(q.shape[1])
    for _ in range(_COLLISION_TRIES * q.shape[1]):
        rows = q[hits] - centre
        left = []
        for j in range(q.shape[1]):
            trial = factors.copy()
            trial[j] *= COLLISION_SHRINK
            left.append(int(np.sum(collision.colliding(centre + trial * rows))))
        factors[int(np.argmin(left))] *= COLLISION_SHRINK
        hits = collision.colliding(centre + factors * (q - centre))
        if not np.any(hits):
            return factors
    return factors


def _collision_free_scale(trajectory: FourierTrajectory, collision: SelfCollision) -> float:
    """The largest factor COLLISION_SHRINK^k (k = 0, 1, ...) of the amplitudes that keeps
    the links apart on the grid."""
    t = trajectory.grid(COLLISION_PER_HARMONIC)
    q, _, _ = trajectory.evaluate(t)
    scale = 1.0
    for _ in range(_COLLISION_TRIES):
        if not np.any(collision.colliding(trajectory.q0 + scale * (q - trajectory.q0))):
            return scale
        scale *= COLLISION_SHRINK
    raise LimitsError(f'the optimised motion brings links together even shrunk to '
                      f'{scale / COLLISION_SHRINK:.2g} of its amplitude')


class _Problem:
    """The optimisation's data: grids, the linear maps from coefficients to motion, limits.

    The variables x (2nL,) are [a, b] of shape (2, n, L) flattened.
    """

    def __init__(self, model: LinearInParameters, limits: JointLimits, n_harmonics: int,
                 period: float) -> None:
        self.model, self.limits = model, limits
        self.n, self.harmonics, self.period = limits.n_joints, n_harmonics, period
        fractions = [float(SEQUENCE_EXCITATION[key]) for key in
                     ('position_fraction', 'velocity_fraction', 'acceleration_fraction')]
        half = 0.5 * (limits.position_max - limits.position_min)
        self.bounds = np.stack([fractions[0] * half, fractions[1] * limits.velocity_max,
                                fractions[2] * limits.acceleration_max])       # (3, n)
        self.omega = 2.0 * math.pi / period * np.arange(1, n_harmonics + 1)  # rad/s
        self.times = self._grid(_SAMPLES_PER_HARMONIC)
        self.maps = self._maps(self.times)                   # (3, M, 2L): x_j -> q, q', q''
        checks = self._maps(self._grid(_CHECKS_PER_HARMONIC))
        # rows ±(motion of joint j at a check) <= bound: as A x + c >= 0, A of (rows, 2nL)
        blocks = []
        for kind in range(3):
            for j in range(self.n):
                rows = np.zeros((checks.shape[1], 2, self.n, n_harmonics))
                rows[:, 0, j, :] = checks[kind][:, :n_harmonics]
                rows[:, 1, j, :] = checks[kind][:, n_harmonics:]
                flat = rows.reshape(checks.shape[1], -1)
                blocks += [-flat, flat]
        self.constraint_matrix = np.vstack(blocks)
        self.reference = self._reference()
        self._checks = checks.shape[1]
        self.constraint_bound = self._constraint_bound()

    def _constraint_bound(self) -> FloatArray:
        return np.concatenate([np.full(2 * self._checks, self.bounds[kind, j])
                               for kind in range(3) for j in range(self.n)])

    def narrow(self, factors: FloatArray) -> None:
        """Narrow each joint's position bound by ``factors`` (n,)."""
        self.bounds[0] *= factors
        self.constraint_bound = self._constraint_bound()

    def _reference(self) -> FloatArray:
        """A (p, p) of the module docstring: the information of the reference motion, each
        joint's rows divided by the variance of the efforts the URDF gives along it (or not
        weighted for a model without ``urdf_parameters``)."""
        t = _REFERENCE_STEP * np.arange(round(_REFERENCE_SECONDS / _REFERENCE_STEP),
                                        dtype=np.float64)
        w = self.model.regressor(*JointSequence(self.limits, seed=REFERENCE_SEED).evaluate(t))
        prior = getattr(self.model, 'urdf_parameters', None)
        if prior is None:
            weights = np.ones(self.n)
        else:
            variance = np.var(w @ prior(), axis=0)
            weights = 1.0 / np.maximum(variance, _LEAST_VARIANCE * variance.max())
        return np.asarray(np.einsum('ijk,j,ijl->kl', w, weights, w) / t.size)

    def _grid(self, per_harmonic: int) -> FloatArray:
        count = per_harmonic * self.harmonics
        return np.arange(count, dtype=np.float64) * (self.period / count)

    def _maps(self, t: FloatArray) -> FloatArray:
        """Maps of one joint's [a, b] (2L,) to q − c, q', q'' at times t: (3, N, 2L)."""
        angle = np.multiply.outer(t, self.omega)
        sin, cos = np.sin(angle), np.cos(angle)
        w = self.omega
        return np.stack([np.hstack([sin / w, -cos / w]), np.hstack([cos, sin]),
                         np.hstack([-sin * w, cos * w])])

    def unpack(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        ab = x.reshape(2, self.n, self.harmonics)
        return ab[0], ab[1]

    def trajectory(self, x: FloatArray) -> FourierTrajectory:
        a, b = self.unpack(x)
        return FourierTrajectory(self.limits.centre, a, b, 1.0 / self.period)

    def motion(self, x: FloatArray) -> Motion:
        """q, q', q'' (M, n) on the regressor grid."""
        a, b = self.unpack(x)
        ab = np.concatenate([a, b], axis=1).T                               # (2L, n)
        q = self.limits.centre + self.maps[0] @ ab
        return q, self.maps[1] @ ab, self.maps[2] @ ab

    def start(self, seed: int) -> FloatArray:
        """Seeded normal coefficients, each joint scaled to 0.9 of its bounds."""
        rng = np.random.default_rng(seed)
        x = rng.standard_normal(2 * self.n * self.harmonics)
        return self.trajectory_x(self.within_limits(self.trajectory(x), shrink=0.9))

    def trajectory_x(self, trajectory: FourierTrajectory) -> FloatArray:
        return np.concatenate([trajectory.a.ravel(), trajectory.b.ravel()])

    def stacked(self, q: FloatArray, qd: FloatArray, qdd: FloatArray) -> FloatArray:
        w = self.model.regressor(q, qd, qdd)
        return w.reshape(-1, w.shape[-1])

    def objective(self, x: FloatArray) -> float:
        """J of the motion of ``x`` (module docstring)."""
        return self.criterion(self.stacked(*self.motion(x)))[0]

    def criterion(self, w: FloatArray) -> tuple[float, FloatArray]:
        """J of the stacked regressor w (rows, p) and its derivative G by w (rows, p); J is
        large and G zero if w is singular."""
        u, s, vt = np.linalg.svd(w, full_matrices=False)
        if not s[-1] > _SINGULAR * s[0]:
            return _SINGULAR_VALUE, np.zeros_like(w)
        m = (vt.T / s ** 2) @ vt                                   # (WᵀW)⁻¹
        ma = m @ self.reference
        trace = float(np.trace(ma))
        value = math.log(trace) + CONDITION_WEIGHT * math.log(s[0] / s[-1])
        g = -2.0 * w @ (ma @ m) / trace + CONDITION_WEIGHT * (
            np.outer(u[:, 0], vt[0]) / s[0] - np.outer(u[:, -1], vt[-1]) / s[-1])
        return value, g

    def gradient(self, x: FloatArray) -> FloatArray:
        """∂ objective / ∂x (2nL,) by the chain rule (module docstring)."""
        q, qd, qdd = self.motion(x)
        w = self.stacked(q, qd, qdd)
        _, g = self.criterion(w)
        count = q.shape[0]
        g = g.reshape(count, self.n, -1)
        per_state = np.zeros((3, count, self.n))       # ∂J / ∂(q, q', q'')_ij
        states = [q, qd, qdd]
        for kind in range(3):
            for j in range(self.n):
                moved = [state.copy() for state in states]
                h = _STEP * max(1.0, float(np.abs(states[kind][:, j]).max()))
                moved[kind][:, j] += h
                dw = (self.model.regressor(*moved) - w.reshape(count, self.n, -1)) / h
                per_state[kind, :, j] = np.einsum('ijk,ijk->i', g, dw)
        # chain to each joint's [a, b]: Σ_kind Σ_i per_state[kind, i, j] maps[kind][i, :]
        grad = np.einsum('kij,kil->jl', per_state, self.maps)              # (n, 2L)
        L = self.harmonics
        return np.concatenate([grad[:, :L].ravel(), grad[:, L:].ravel()]).astype(np.float64)

    def slack(self, x: FloatArray) -> FloatArray:
        """bound ∓ (motion at each check): >= 0 within the limits."""
        return self.constraint_bound + self.constraint_matrix @ x

    def feasible(self, x: FloatArray) -> bool:
        return bool(np.all(self.slack(x) >= -1e-9))

    def within_limits(self, trajectory: FourierTrajectory, *,
                      shrink: float = 1.0) -> FourierTrajectory:
        """The trajectory scaled down per joint where a dense grid finds it beyond
        ``shrink`` times its bounds."""
        peaks = np.stack(trajectory.peaks(_DENSE_PER_HARMONIC))              # (3, n)
        with np.errstate(divide='ignore'):
            scale = np.min(np.where(peaks > 0, shrink * self.bounds / peaks, np.inf), axis=0)
        scale = np.minimum(scale, 1.0) if shrink == 1.0 else scale
        return FourierTrajectory(trajectory.q0, trajectory.a * scale[:, None],
                                 trajectory.b * scale[:, None], trajectory.base_frequency_hz)

    def condition(self, trajectory: FourierTrajectory) -> float:
        q, qd, qdd = trajectory.evaluate(self.times)
        s = np.linalg.svd(self.stacked(q, qd, qdd), compute_uv=False)
        return float(s[0] / s[-1]) if s[-1] > 0 else float('inf')


def plan_condition(plan: ExcitationPlan, model: LinearInParameters, seconds: float,
                   step: float) -> float:
    """cond(W) of ``model``'s regressor stacked over a plan's first ``seconds`` of
    excitation after its approach, sampled every ``step`` (s) (∞ if singular)."""
    t = plan.approach_duration + step * np.arange(max(1, round(seconds / step)))
    return condition_number(model, *plan.evaluate(t))
