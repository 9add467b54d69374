"""The simulator's ``sequence`` excitation on a real arm's limits: the same seeds and blends.

:class:`~scara_ident_ros.sim.sequence.SequenceTrajectory` builds the persistent excitation
of a simulated robot: a new random Fourier excitation F_k every period T, drawn from
(seed, k, attempt) and scaled to fractions of the limits, consecutive ones joined by the
quintic smoothstep s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, a blend redrawn if it would leave the limits.
It also bounds the efforts, through the robot's dynamics model (the SCARA's, or Pinocchio's
from a URDF with trusted inertias). On a real arm the excitation trusts only the URDF's
limits: :class:`JointSequence` is the same construction on
:class:`~scara_ident_ros.dynamics.joint_limits.JointLimits`, without the effort bound.
With efforts that never bind, it gives the simulator's sequence to rounding
(``test/excitation/test_joint_sequence.py`` checks it on the SCARA).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.sim.sequence import SEQUENCE_EXCITATION, SEQUENCE_LIMITS, smoothstep
from scara_ident_ros.sim.trajectory import FourierTrajectory

__all__ = ['JointSequence']

_GRID_PER_HARMONIC = 200       # check points per period of the highest harmonic
Motion = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


class JointSequence:
    """Endless seeded sequence of random Fourier excitations of n joints, blended smoothly.

    Parameters
    ----------
    limits : JointLimits
        The limits the motion keeps to (with the safety margins already taken off).
    seed : int
        Seed (>= 0); equal seeds and limits give equal sequences.
    excitation : mapping, optional
        ``n_harmonics``, ``base_frequency_hz`` and the ``position_fraction``,
        ``velocity_fraction`` and ``acceleration_fraction`` of each excitation; default the
        simulator's :data:`~scara_ident_ros.sim.sequence.SEQUENCE_EXCITATION`.
    limit_fractions : mapping, optional
        ``position_fraction``, ``velocity_fraction`` and ``acceleration_fraction`` that
        every blend keeps to; default the simulator's
        :data:`~scara_ident_ros.sim.sequence.SEQUENCE_LIMITS`.
    max_attempts : int
        Candidates drawn for one excitation before giving up with a ValueError.
    """

    def __init__(self, limits: JointLimits, *, seed: int,
                 excitation: Mapping[str, Any] | None = None,
                 limit_fractions: Mapping[str, float] | None = None,
                 max_attempts: int = 50) -> None:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f'seed must be an integer >= 0, got {seed!r}')
        settings = dict(SEQUENCE_EXCITATION if excitation is None else excitation)
        fractions = dict(SEQUENCE_LIMITS if limit_fractions is None else limit_fractions)
        self.limits = limits
        self.seed = seed
        self.n_harmonics = int(settings['n_harmonics'])
        self.base_frequency_hz = float(settings['base_frequency_hz'])
        self.period = 1.0 / self.base_frequency_hz                       # s, one segment
        self.max_attempts = max_attempts
        self._draw_fractions = [float(settings[key]) for key in
                                ('position_fraction', 'velocity_fraction',
                                 'acceleration_fraction')]
        half = 0.5 * (limits.position_max - limits.position_min)
        clear = (1.0 - fractions['position_fraction']) * half
        self._low, self._high = limits.position_min + clear, limits.position_max - clear
        self._velocity_max = fractions['velocity_fraction'] * limits.velocity_max
        self._acceleration_max = fractions['acceleration_fraction'] * limits.acceleration_max
        self._chain: list[FourierTrajectory] = [self._draw(0, 0)]

    def excitation(self, k: int) -> FourierTrajectory:
        """Excitation F_k, the motion at the start kT of segment k (built if need be)."""
        while len(self._chain) <= k:
            j = len(self._chain)
            for attempt in range(self.max_attempts):
                candidate = self._draw(j, attempt)
                if self._within_limits(self._chain[j - 1], candidate):
                    self._chain.append(candidate)
                    break
            else:
                raise ValueError(f'no excitation {j} of {self.max_attempts} candidates keeps '
                                 f'its blend within the limits (seed {self.seed})')
        return self._chain[k]

    def evaluate(self, t: NDArray[np.float64]) -> Motion:
        """q, q', q'' at times t (N,) >= 0 (s), each of shape (N, n)."""
        t = np.asarray(t, dtype=float)
        if np.any(t < 0.0) or not np.all(np.isfinite(t)):
            raise ValueError('t must be finite and >= 0 (the sequence starts at t = 0)')
        segment = np.floor(t / self.period).astype(np.int64)
        n = self.limits.n_joints
        q, qd, qdd = (np.empty((t.size, n)) for _ in range(3))
        for k in np.unique(segment).tolist():
            rows = segment == k
            q[rows], qd[rows], qdd[rows] = self._blend(
                self.excitation(k), self.excitation(k + 1), t[rows] - k * self.period)
        return q, qd, qdd

    def _blend(self, first: FourierTrajectory, second: FourierTrajectory,
               u: NDArray[np.float64]) -> Motion:
        """The blend from ``first`` to ``second`` at local times u (N,) in [0, T]."""
        q_a, qd_a, qdd_a = first.evaluate(u)
        q_b, qd_b, qdd_b = second.evaluate(u)
        s, ds, dds = smoothstep(u / self.period, self.period)
        dq, dqd = q_b - q_a, qd_b - qd_a
        return (q_a + s * dq, qd_a + s * dqd + ds * dq,
                qdd_a + s * (qdd_b - qdd_a) + 2.0 * ds * dqd + dds * dq)

    def _draw(self, k: int, attempt: int) -> FourierTrajectory:
        """Candidate ``attempt`` of excitation k, seeded from (seed, k, attempt) only, scaled
        per joint to the fractions of the half-range, velocity and acceleration limits."""
        seed = int(np.random.SeedSequence((self.seed, k, attempt)).generate_state(1)[0])
        rng = np.random.default_rng(seed)
        n = self.limits.n_joints
        a = rng.standard_normal((n, self.n_harmonics))
        b = rng.standard_normal((n, self.n_harmonics))
        centre = self.limits.centre
        unit = FourierTrajectory(centre, a, b, self.base_frequency_hz)
        excursion, speed, accel = unit.peaks()
        half = 0.5 * (self.limits.position_max - self.limits.position_min)
        position, velocity, acceleration = self._draw_fractions
        scale = np.minimum.reduce([position * half / excursion,
                                   velocity * self.limits.velocity_max / speed,
                                   acceleration * self.limits.acceleration_max / accel])
        return FourierTrajectory(centre, a * scale[:, None], b * scale[:, None],
                            self.base_frequency_hz)

    def _within_limits(self, first: FourierTrajectory, second: FourierTrajectory) -> bool:
        """Whether the blend of two excitations keeps to the fractions on a dense grid."""
        u = np.linspace(0.0, self.period, _GRID_PER_HARMONIC * self.n_harmonics + 1)
        q, qd, qdd = self._blend(first, second, u)
        return not (np.any(q < self._low) or np.any(q > self._high)
                    or np.any(np.abs(qd) > self._velocity_max)
                    or np.any(np.abs(qdd) > self._acceleration_max))
