"""Periodic excitation trajectories: finite Fourier series (Swevers et al., 1997).

For joint i with L harmonics of the base pulsation ωf = 2π f:

    q_i(t)   = q0_i + Σ_l  a_il / (ωf l) sin(ωf l t) − b_il / (ωf l) cos(ωf l t)
    q_i'(t)  =        Σ_l  a_il cos(ωf l t) + b_il sin(ωf l t)
    q_i''(t) =        Σ_l −a_il ωf l sin(ωf l t) + b_il ωf l cos(ωf l t)

The motion is periodic with period 1/f, band-limited (good for estimating q'' and for
averaging noise) and its derivatives are analytic, so the reference for q, q', q'' is exact.

A robot here is the SCARA's :class:`ScaraParams` or any object with the same limit accessors
(``array(name)``, ``position_centre``, ``effort_max``) and a batch ``inverse_dynamics``, such
as :class:`~scara_ident_ros.sim.pinocchio_robot.PinocchioRobot`: see :data:`Robot`.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Union

import numpy as np

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ScaraParams

if TYPE_CHECKING:
    from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot

__all__ = ['FourierTrajectory', 'PRESETS', 'Robot', 'inverse_dynamics_of']

#: A robot whose limits and dynamics bound an excitation: the SCARA or a URDF robot.
Robot = Union[ScaraParams, 'PinocchioRobot']


def inverse_dynamics_of(robot: Robot) -> Callable[[np.ndarray, np.ndarray, np.ndarray],
                                                  np.ndarray]:
    """The robot's batch inverse dynamics (q, q', q'') (N, n) -> efforts (N, n), N·m or N.

    The SCARA's closed-form :class:`ScaraModel`, or the robot's own ``inverse_dynamics``.
    """
    if isinstance(robot, ScaraParams):
        return ScaraModel(robot).inverse_dynamics
    return robot.inverse_dynamics

#: Named excitation settings, keyword arguments of :meth:`FourierTrajectory.random`.
#: The fractions are of the joint half-range and of the velocity, acceleration and effort
#: limits of :class:`ScaraParams`; what is left is the safety margin.
PRESETS: dict[str, dict[str, Any]] = {
    # slow, small: 10 s period, position-limited, a fraction of the speed limits
    'gentle': {'n_harmonics': 3, 'base_frequency_hz': 0.1, 'position_fraction': 0.5,
               'velocity_fraction': 0.3, 'acceleration_fraction': 0.3,
               'effort_fraction': 0.5},
    # 5 s period, most of the workspace, up to ~0.6 of the speed limits
    'standard': {'n_harmonics': 5, 'base_frequency_hz': 0.2, 'position_fraction': 0.8,
                 'velocity_fraction': 0.8, 'acceleration_fraction': 0.8,
                 'effort_fraction': 0.8},
    # 3.3 s period, acceleration-limited on the arm joints
    'aggressive': {'n_harmonics': 6, 'base_frequency_hz': 0.3, 'position_fraction': 0.9,
                   'velocity_fraction': 0.9, 'acceleration_fraction': 0.9,
                   'effort_fraction': 0.9},
}

_GRID_PER_HARMONIC = 200       # samples per period of the highest harmonic when scaling


class FourierTrajectory:
    """A finite Fourier series per joint with analytic q, q', q''.

    Parameters
    ----------
    q0 : array_like of shape (n,)
        Mean position of each of the n joints over a period (rad or m; the SCARA: rad, rad,
        m, rad).
    a, b : array_like of shape (n, L)
        Sine and cosine coefficients of the velocity (rad/s or m/s).
    base_frequency_hz : float
        Fundamental frequency f (Hz); the period is 1/f.
    """

    def __init__(self, q0: np.ndarray, a: np.ndarray, b: np.ndarray,
                 base_frequency_hz: float) -> None:
        q0 = np.array(q0, dtype=float)
        a = np.array(a, dtype=float)
        b = np.array(b, dtype=float)
        if q0.ndim != 1 or q0.size < 1:
            raise ValueError(f'q0 must have shape (n,), got {q0.shape}')
        n = q0.size
        if a.ndim != 2 or a.shape[0] != n or a.shape[1] < 1 or b.shape != a.shape:
            raise ValueError(f'a and b must have the same shape ({n}, L) with L >= 1, '
                             f'got {a.shape} and {b.shape}')
        if not (np.all(np.isfinite(q0)) and np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            raise ValueError('q0, a and b must be finite')
        if not (math.isfinite(base_frequency_hz) and base_frequency_hz > 0.0):
            raise ValueError(f'base_frequency_hz must be > 0, got {base_frequency_hz!r}')
        for array in (q0, a, b):
            array.setflags(write=False)
        self.q0 = q0
        self.a = a
        self.b = b
        self.base_frequency_hz = float(base_frequency_hz)
        omega = 2.0 * math.pi * self.base_frequency_hz * np.arange(1, a.shape[1] + 1)  # rad/s
        self._omega = omega
        # coefficient matrices (L, n) so that rows of sin/cos (N, L) map to (N, n)
        self._pos_sin, self._pos_cos = (a / omega).T, (-b / omega).T
        self._acc_sin, self._acc_cos = (-a * omega).T, (b * omega).T

    @property
    def n_harmonics(self) -> int:
        """Number of harmonics L."""
        return int(self.a.shape[1])

    @property
    def period(self) -> float:
        """Period 1/f of the motion (s)."""
        return 1.0 / self.base_frequency_hz

    def __repr__(self) -> str:
        return (f'FourierTrajectory(n_harmonics={self.n_harmonics}, '
                f'base_frequency_hz={self.base_frequency_hz!r}, q0={self.q0.tolist()!r})')

    def evaluate(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Desired q (rad or m), q' (…/s) and q'' (…/s²) at time(s) ``t`` (s): each (n,),
        or (N, n) for N times."""
        t = np.asarray(t, dtype=float)
        if t.ndim > 1:
            raise ValueError(f't must be a scalar or of shape (N,), got {t.shape}')
        angle = np.multiply.outer(np.atleast_1d(t), self._omega)          # (N, L), rad
        sin, cos = np.sin(angle), np.cos(angle)
        q = self.q0 + sin @ self._pos_sin + cos @ self._pos_cos
        qd = cos @ self.a.T + sin @ self.b.T
        qdd = sin @ self._acc_sin + cos @ self._acc_cos
        if t.ndim == 0:
            return q[0], qd[0], qdd[0]
        return q, qd, qdd

    def grid(self, points_per_harmonic: int = _GRID_PER_HARMONIC) -> np.ndarray:
        """Evenly spaced times over one period, shape (points_per_harmonic · L,) (s)."""
        n = points_per_harmonic * self.n_harmonics
        return np.arange(n) * (self.period / n)

    def peaks(self, points_per_harmonic: int = _GRID_PER_HARMONIC
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Largest |q − q0|, |q'| and |q''| per joint over a dense grid of one period.

        Returns
        -------
        tuple of three ndarray of shape (n,)
            Peak excursion, speed and acceleration (SI).
        """
        q, qd, qdd = self.evaluate(self.grid(points_per_harmonic))
        return (np.abs(q - self.q0).max(axis=0), np.abs(qd).max(axis=0),
                np.abs(qdd).max(axis=0))

    @classmethod
    def random(cls, params: Robot, *, seed: int, n_harmonics: int = 5,
               base_frequency_hz: float = 0.2, position_fraction: float = 0.8,
               velocity_fraction: float = 0.8, acceleration_fraction: float = 0.8,
               effort_fraction: float | None = 0.8) -> FourierTrajectory:
        """A random excitation scaled to stay inside the joint limits with a margin.

        Coefficients are drawn from a standard normal distribution, then each joint is
        scaled so that over a dense grid of one period its excursion about the middle of its
        range, its speed and its acceleration stay within the given fractions of the
        half-range and of the limits. If ``effort_fraction`` is given, the whole motion is
        then shrunk until the model's inverse dynamics needs at most that fraction of
        ``effort_max`` on every joint.

        Fractions are in (0, 1]; ``effort_fraction`` None does not check efforts. Equal
        seeds give equal trajectories; the defaults are the ``'standard'`` preset's.

        Raises
        ------
        ValueError
            For out-of-range settings, or when the efforts cannot be brought inside the
            limits (e.g. gravity alone exceeds them).
        """
        if isinstance(n_harmonics, bool) or not isinstance(n_harmonics, int) or n_harmonics < 1:
            raise ValueError(f'n_harmonics must be an integer >= 1, got {n_harmonics!r}')
        fractions = {'position_fraction': position_fraction,
                     'velocity_fraction': velocity_fraction,
                     'acceleration_fraction': acceleration_fraction}
        if effort_fraction is not None:
            fractions['effort_fraction'] = effort_fraction
        for name, value in fractions.items():
            if not 0.0 < value <= 1.0:
                raise ValueError(f'{name} must be in (0, 1], got {value!r}')
        rng = np.random.default_rng(seed)
        n = len(params.effort_max)
        a = rng.standard_normal((n, n_harmonics))
        b = rng.standard_normal((n, n_harmonics))
        unit = cls(params.position_centre, a, b, base_frequency_hz)
        excursion, speed, accel = unit.peaks()
        half_range = 0.5 * (params.array('position_max') - params.array('position_min'))
        scale = np.minimum.reduce([position_fraction * half_range / excursion,
                                   velocity_fraction * params.array('velocity_max') / speed,
                                   acceleration_fraction * params.array('acceleration_max')
                                   / accel])
        trajectory = cls(params.position_centre, a * scale[:, None], b * scale[:, None],
                         base_frequency_hz)
        if effort_fraction is None:
            return trajectory
        inverse_dynamics = inverse_dynamics_of(params)
        effort_max = params.array('effort_max')
        for _ in range(100):
            q, qd, qdd = trajectory.evaluate(trajectory.grid())
            ratio = np.abs(inverse_dynamics(q, qd, qdd)).max(axis=0) / effort_max
            if ratio.max() <= effort_fraction:
                return trajectory
            shrink = max(0.5, min(0.95, effort_fraction / ratio.max()))
            trajectory = cls(trajectory.q0, trajectory.a * shrink, trajectory.b * shrink,
                             base_frequency_hz)
        raise ValueError(f'cannot keep the efforts within {effort_fraction} of effort_max '
                         f'{params.effort_max}: the motion needs {ratio.tolist()} of them')
