"""Persistent excitation: an endless sequence of random Fourier excitations, joined smoothly.

One periodic excitation traces one closed curve in the 12-D space of (q, q', q''), so a
network learnt online from it knows that curve only. This trajectory draws a new random
excitation F_k every period T and blends consecutive ones: during segment k, for t in
[kT, (k+1)T) and τ = (t − kT)/T,

    q(t)   = (1 − s) F_k(t) + s F_{k+1}(t)
    q'(t)  = (1 − s) F_k'(t) + s F_{k+1}'(t) + s' (F_{k+1}(t) − F_k(t))
    q''(t) = (1 − s) F_k''(t) + s F_{k+1}''(t) + 2 s' (F_{k+1}'(t) − F_k'(t))
             + s'' (F_{k+1}(t) − F_k(t))

with the quintic smoothstep s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, whose first and second derivatives
vanish at τ = 0 and τ = 1. Every F_k is T-periodic, so segment k ends in F_{k+1}'s state at
(k+1)T, where segment k+1 starts: q, q' and q'' are continuous at every time.

Each blended segment is checked on a dense grid against the limits (position range,
``velocity_max``, ``acceleration_max`` and ``effort_max`` through the inverse dynamics, with
the margins of the ``'standard'`` preset) when it is first built; if it would leave them,
F_{k+1} is drawn again. Candidate a of excitation k is seeded from (seed, k, a) only, and
the chain is always built in order from k = 0, so equal seeds give equal sequences
whatever order times are evaluated in.
"""
from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping
from typing import Any

import numpy as np

from scara_ident_ros.sim.trajectory import PRESETS, FourierTrajectory, Robot, inverse_dynamics_of

__all__ = ['SequenceTrajectory', 'SEQUENCE_EXCITATION', 'SEQUENCE_LIMITS']

_FRACTIONS = ('position_fraction', 'velocity_fraction', 'acceleration_fraction',
              'effort_fraction')

#: Fractions of the half-range and of the velocity, acceleration and effort limits that
#: every blended segment must respect: the margins of the ``'standard'`` preset.
SEQUENCE_LIMITS: dict[str, float] = {name: PRESETS['standard'][name] for name in _FRACTIONS}

#: Keyword arguments of :meth:`FourierTrajectory.random` for each excitation: the
#: ``'standard'`` preset (5 harmonics, 5 s period) with 0.95 of its fractions, because a
#: blend gains the terms in s' and s'' on top of the two excitations' own speeds and
#: accelerations; with these, a blend nearly never needs to be drawn again.
SEQUENCE_EXCITATION: dict[str, Any] = {
    **PRESETS['standard'],
    'position_fraction': 0.76, 'velocity_fraction': 0.76, 'acceleration_fraction': 0.76,
    'effort_fraction': 0.76,
}

_GRID_PER_HARMONIC = 200       # check points per period of the highest harmonic


def smoothstep(tau: np.ndarray, duration: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic smoothstep s(τ) and its time derivatives s' (1/s), s'' (1/s²), shape (N, 1).

    τ (N,) is clipped to [0, 1]; ``duration`` (s) is the time τ takes from 0 to 1. The
    sequence's blends and the excitation's approach and stops all use it.
    """
    tau = np.clip(tau, 0.0, 1.0)[:, None]
    rest = 1.0 - tau
    s = tau ** 3 * (10.0 + tau * (6.0 * tau - 15.0))
    ds = 30.0 * (tau * rest) ** 2 / duration
    dds = 60.0 * tau * rest * (1.0 - 2.0 * tau) / duration ** 2
    return s, ds, dds


def _blend(first: FourierTrajectory, second: FourierTrajectory, u: np.ndarray,
           duration: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q', q'' of the blend of two T-periodic excitations at local times u (N,) in [0, T].

    Returns three ndarray of shape (N, n).
    """
    q_a, qd_a, qdd_a = first.evaluate(u)
    q_b, qd_b, qdd_b = second.evaluate(u)
    s, ds, dds = smoothstep(u / duration, duration)
    dq, dqd = q_b - q_a, qd_b - qd_a
    q = q_a + s * dq
    qd = qd_a + s * dqd + ds * dq
    qdd = qdd_a + s * (qdd_b - qdd_a) + 2.0 * ds * dqd + dds * dq
    return q, qd, qdd


class SequenceTrajectory:
    """Endless, seeded sequence of random Fourier excitations, a new one every period.

    Parameters
    ----------
    params : ScaraParams or PinocchioRobot
        Robot whose limits and dynamics bound the motion.
    seed : int
        Seed (>= 0); equal seeds give equal sequences.
    excitation : mapping, optional
        Keyword arguments of :meth:`FourierTrajectory.random` for each excitation; default
        :data:`SEQUENCE_EXCITATION`. The segment duration T is the excitations' period.
    limit_fractions : mapping, optional
        ``position_fraction``, ``velocity_fraction``, ``acceleration_fraction`` and
        ``effort_fraction`` in (0, 1] that every blended segment must respect; default
        :data:`SEQUENCE_LIMITS`.
    max_attempts : int, optional
        Candidates drawn for one excitation before giving up with a ValueError.
    cache_size : int, optional
        Excitations kept in memory (least recently used dropped first), >= 2.

    Raises
    ------
    ValueError
        For invalid settings, or when no candidate of an excitation keeps its blend inside
        the limits (raised by :meth:`evaluate` for later excitations).

    Notes
    -----
    Excitation k depends only on (seed, k), but building it needs the accepted excitations
    0..k−1: evaluating at time t builds (once) and checks every segment up to t, so a first
    evaluation far ahead costs the checks of every segment before it. Only the accepted
    candidate number of each excitation is kept for good; in order, as the simulator
    evaluates, each segment is built and checked once per period T.
    """

    def __init__(self, params: Robot, *, seed: int,
                 excitation: Mapping[str, Any] | None = None,
                 limit_fractions: Mapping[str, float] | None = None,
                 max_attempts: int = 50, cache_size: int = 8) -> None:
        for name, value, minimum in (('seed', seed, 0), ('max_attempts', max_attempts, 1),
                                     ('cache_size', cache_size, 2)):
            if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
                raise ValueError(f'{name} must be an integer >= {minimum}, got {value!r}')
        limits = dict(SEQUENCE_LIMITS if limit_fractions is None else limit_fractions)
        if sorted(limits) != sorted(_FRACTIONS):
            raise ValueError(f'limit_fractions must have exactly the keys '
                             f'{", ".join(_FRACTIONS)}, got {", ".join(sorted(limits))}')
        for name, fraction in limits.items():
            if not 0.0 < fraction <= 1.0:
                raise ValueError(f'limit_fractions[{name!r}] must be in (0, 1], '
                                 f'got {fraction!r}')
        self.params = params
        self.seed = seed
        self.excitation_settings: dict[str, Any] = dict(
            SEQUENCE_EXCITATION if excitation is None else excitation)
        self.limit_fractions = limits
        self.max_attempts = max_attempts
        self.cache_size = cache_size
        self._inverse_dynamics = inverse_dynamics_of(params)
        low, high = params.array('position_min'), params.array('position_max')
        margin = (1.0 - limits['position_fraction']) * 0.5 * (high - low)
        self._position_low, self._position_high = low + margin, high - margin   # rad, m
        self._velocity_max = limits['velocity_fraction'] * params.array('velocity_max')
        self._acceleration_max = (limits['acceleration_fraction']
                                  * params.array('acceleration_max'))
        self._effort_max = limits['effort_fraction'] * params.array('effort_max')
        self._cache: OrderedDict[int, FourierTrajectory] = OrderedDict()
        self._attempts: list[int] = [0]        # accepted candidate of each excitation built
        first = self._draw(0, 0)               # validates the excitation settings
        self._remember(0, first)
        self._duration = first.period          # s
        self.q0 = np.array(params.position_centre, dtype=float)
        self.q0.setflags(write=False)

    # -- description --------------------------------------------------------------------------

    @property
    def period(self) -> float:
        """Duration T of one segment, the period of every excitation (s).

        The sequence itself is not periodic.
        """
        return self._duration

    @property
    def n_harmonics(self) -> int:
        """Number of harmonics L of each excitation."""
        return self.excitation(0).n_harmonics

    @property
    def base_frequency_hz(self) -> float:
        """Fundamental frequency 1/T of each excitation (Hz)."""
        return self.excitation(0).base_frequency_hz

    def __repr__(self) -> str:
        return (f'SequenceTrajectory(seed={self.seed}, period={self.period!r}, '
                f'n_harmonics={self.n_harmonics}, q0={self.q0.tolist()!r})')

    # -- evaluation ---------------------------------------------------------------------------

    def evaluate(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Desired position, velocity and acceleration at time(s) t.

        Parameters
        ----------
        t : float or array_like of shape (N,)
            Time (s), >= 0, in any order; an array may span several segments.

        Returns
        -------
        q, qd, qdd : ndarray of shape (n,), or (N, n) for an array of times
            Position (rad or m), velocity (…/s) and acceleration (…/s²).

        Raises
        ------
        ValueError
            For a time that is negative or not finite, or of more than one dimension.
        """
        t = np.asarray(t, dtype=float)
        if t.ndim > 1:
            raise ValueError(f't must be a scalar or of shape (N,), got {t.shape}')
        times = np.atleast_1d(t)
        if not np.all(np.isfinite(times)) or np.any(times < 0.0):
            raise ValueError('t must be finite and >= 0 (the sequence starts at t = 0)')
        duration = self._duration
        segment = np.floor(times / duration).astype(np.int64)
        if times.size and segment[0] == segment[-1] and np.all(segment == segment[0]):
            k = int(segment[0])
            q, qd, qdd = self._segment(k, times - k * duration)
        else:
            q, qd, qdd = (np.empty((times.size, self.q0.size)) for _ in range(3))
            for k in np.unique(segment).tolist():
                rows = segment == k
                q[rows], qd[rows], qdd[rows] = self._segment(k, times[rows] - k * duration)
        if t.ndim == 0:
            return q[0], qd[0], qdd[0]
        return q, qd, qdd

    def grid(self, points_per_harmonic: int = _GRID_PER_HARMONIC, *,
             segments: int = 1) -> np.ndarray:
        """Evenly spaced times over the first ``segments`` segments (s).

        Returns
        -------
        ndarray of shape (points_per_harmonic · L · segments,)
            Times from 0 to segments · T, end excluded.
        """
        n = points_per_harmonic * self.n_harmonics * segments
        return np.arange(n) * (segments * self._duration / n)

    def peaks(self, points_per_harmonic: int = _GRID_PER_HARMONIC, *, segments: int = 1
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Largest |q − q0|, |q'| and |q''| per joint over :meth:`grid`.

        Returns
        -------
        tuple of three ndarray of shape (n,)
            Peak excursion, speed and acceleration (SI).
        """
        q, qd, qdd = self.evaluate(self.grid(points_per_harmonic, segments=segments))
        return (np.abs(q - self.q0).max(axis=0), np.abs(qd).max(axis=0),
                np.abs(qdd).max(axis=0))

    def excitation(self, k: int) -> FourierTrajectory:
        """Excitation F_k, the motion at the start kT of segment k (built if need be).

        Parameters
        ----------
        k : int
            Index of the excitation, >= 0.
        """
        if isinstance(k, bool) or not isinstance(k, int) or k < 0:
            raise ValueError(f'k must be an integer >= 0, got {k!r}')
        self._build_chain(k)
        found = self._cache.get(k)
        if found is not None:
            self._cache.move_to_end(k)
            return found
        trajectory = self._draw(k, self._attempts[k])
        self._remember(k, trajectory)
        return trajectory

    def attempt(self, k: int) -> int:
        """Number of the accepted candidate of excitation k: 0 unless earlier ones were
        redrawn because their blend with excitation k − 1 would have left the limits."""
        self.excitation(k)
        return self._attempts[k]

    # -- internals ----------------------------------------------------------------------------

    def _segment(self, k: int, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q', q'' of segment k at local times u = t − kT (N,), three (N, n) arrays."""
        return _blend(self.excitation(k), self.excitation(k + 1), u, self._duration)

    def _draw(self, k: int, attempt: int) -> FourierTrajectory:
        """Candidate ``attempt`` of excitation k, seeded from (seed, k, attempt) only."""
        seed = int(np.random.SeedSequence((self.seed, k, attempt)).generate_state(1)[0])
        return FourierTrajectory.random(self.params, seed=seed, **self.excitation_settings)

    def _remember(self, k: int, trajectory: FourierTrajectory) -> None:
        self._cache[k] = trajectory
        self._cache.move_to_end(k)
        while len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)

    def _build_chain(self, k: int) -> None:
        """Choose, in order, the accepted candidates of excitations up to k."""
        while len(self._attempts) <= k:
            j = len(self._attempts)
            previous = self.excitation(j - 1)
            for attempt in range(self.max_attempts):
                candidate = self._draw(j, attempt)
                if self._within_limits(previous, candidate):
                    self._attempts.append(attempt)
                    self._remember(j, candidate)
                    break
            else:
                raise ValueError(
                    f'no excitation {j} of {self.max_attempts} candidates keeps segment '
                    f'{j - 1} within {self.limit_fractions} of the limits (seed {self.seed})')

    def _within_limits(self, first: FourierTrajectory, second: FourierTrajectory) -> bool:
        """Whether the blend of two excitations respects the limits on a dense grid."""
        n = _GRID_PER_HARMONIC * max(first.n_harmonics, second.n_harmonics)
        u = np.linspace(0.0, self._duration, n + 1)
        q, qd, qdd = _blend(first, second, u, self._duration)
        if (np.any(q < self._position_low) or np.any(q > self._position_high)
                or np.any(np.abs(qd) > self._velocity_max)
                or np.any(np.abs(qdd) > self._acceleration_max)):
            return False
        effort = self._inverse_dynamics(q, qd, qdd)
        return bool(np.all(np.abs(effort) <= self._effort_max))
