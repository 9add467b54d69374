"""The whole planned motion of an excitation run: the approach, then the sequence.

Plan time t starts (t = 0) at rest at the arm's current position q_s. During the approach,
t in [0, T_a), the plan blends from that rest into the first excitation F_0 with the same
quintic smoothstep as the sequence's blends, running F_0 (periodic) over [−T_a, 0):

    q(t)   = q_s + s(τ) (F_0(u) − q_s),                     u = t − T_a,  τ = t / T_a
    q'(t)  = s F_0'(u) + s' (F_0(u) − q_s)
    q''(t) = s F_0''(u) + 2 s' F_0'(u) + s'' (F_0(u) − q_s)

so it leaves q_s at rest (s, s', s'' vanish at τ = 0) and reaches the sequence's state at
its t = 0 exactly (s = 1, s' = s'' = 0 at τ = 1): q, q', q'' are continuous everywhere.
Every position of the approach lies between q_s and F_0, so within the limits if q_s is;
T_a is the shortest of a geometric series of durations (from 1 s) whose velocity and
acceleration keep to the same fractions of the limits as the sequence's blends. From
t = T_a on, the plan is the sequence at t − T_a. The sequence is the random
:class:`~scara_ident_ros.excitation.joint_sequence.JointSequence` by default, or any
:class:`Excitation`: the optimised periodic motion of
:mod:`~scara_ident_ros.excitation.optimized_excitation`.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from scara_ident_ros.dynamics.joint_limits import JointLimits, LimitsError
from scara_ident_ros.excitation.duration_search import shortest_duration
from scara_ident_ros.excitation.joint_sequence import JointSequence, Motion
from scara_ident_ros.sim.sequence import SEQUENCE_LIMITS, smoothstep
from scara_ident_ros.sim.trajectory import FourierTrajectory

__all__ = ['Excitation', 'ExcitationPlan']

_APPROACH_MIN = 1.0          # s, shortest approach
_APPROACH_MAX = 300.0        # s, longest approach tried
_APPROACH_GROWTH = 1.25      # ratio of two approach durations tried
_CHECK_STEP = 0.005          # s between the samples an approach is checked on


class Excitation(Protocol):
    """The motion after the approach, as :class:`JointSequence` gives it."""

    def excitation(self, k: int) -> FourierTrajectory:
        """The Fourier motion F_k at the start of segment k (F_0: what the approach joins)."""
        ...

    def evaluate(self, t: NDArray[np.float64]) -> Motion:
        """q, q', q'' at times t (N,) >= 0 (s), each of shape (N, n)."""
        ...


class ExcitationPlan:
    """From rest at ``start``, the approach, then the endless sequence excitation.

    Parameters
    ----------
    limits : JointLimits
        The limits with the safety margins taken off (what the motion keeps to).
    start : ndarray of shape (n,)
        The arm's position at rest when the plan starts (rad or m), inside the robot's
        limits (it may lie in the margins: the approach leaves them).
    seed : int
        Seed of the sequence (:class:`JointSequence`).
    excitation : Excitation, optional
        The motion after the approach instead of the random sequence (e.g. an
        :class:`~scara_ident_ros.excitation.optimized_excitation.OptimizedExcitation`
        within the same limits).

    Attributes
    ----------
    sequence : Excitation
        The excitation after the approach.
    approach_duration : float
        T_a (s).
    """

    def __init__(self, limits: JointLimits, start: NDArray[np.float64], *,
                 seed: int, excitation: Excitation | None = None) -> None:
        start = np.array(start, dtype=float)
        if start.shape != (limits.n_joints,) or not np.all(np.isfinite(start)):
            raise LimitsError(f'start must be {limits.n_joints} finite positions, '
                                    f'got {start!r}')
        self.limits = limits
        self.start = start
        self.sequence: Excitation = (JointSequence(limits, seed=seed) if excitation is None
                                     else excitation)
        self.approach_duration = self._shortest_approach()

    def evaluate(self, t: npt.ArrayLike) -> Motion:
        """Planned q, q', q'' at plan times t (N,) >= 0 (s), each of shape (N, n)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if np.any(t < 0.0) or not np.all(np.isfinite(t)):
            raise ValueError('plan times must be finite and >= 0')
        n = self.limits.n_joints
        q, qd, qdd = (np.empty((t.size, n)) for _ in range(3))
        early = t < self.approach_duration
        if np.any(early):
            q[early], qd[early], qdd[early] = self._approach(t[early], self.approach_duration)
        if not np.all(early):
            late = ~early
            q[late], qd[late], qdd[late] = self.sequence.evaluate(
                t[late] - self.approach_duration)
        return q, qd, qdd

    def _approach(self, t: NDArray[np.float64], duration: float) -> Motion:
        """The approach of ``duration`` T_a at times t (N,) in [0, T_a]."""
        q_f, qd_f, qdd_f = self.sequence.excitation(0).evaluate(t - duration)
        s, ds, dds = smoothstep(t / duration, duration)
        gap = q_f - self.start
        return (self.start + s * gap, s * qd_f + ds * gap,
                s * qdd_f + 2.0 * ds * qd_f + dds * gap)

    def _shortest_approach(self) -> float:
        """The shortest T_a of the series keeping to the blends' fractions of the limits."""
        velocity_max = SEQUENCE_LIMITS['velocity_fraction'] * self.limits.velocity_max
        acceleration_max = (SEQUENCE_LIMITS['acceleration_fraction']
                            * self.limits.acceleration_max)

        def keeps_to_limits(duration: float) -> float | None:
            t = np.linspace(0.0, duration, int(np.ceil(duration / _CHECK_STEP)) + 1)
            _, qd, qdd = self._approach(t, duration)
            fits = np.all(np.abs(qd) <= velocity_max) and np.all(np.abs(qdd) <= acceleration_max)
            return duration if fits else None

        found = shortest_duration(keeps_to_limits, shortest=_APPROACH_MIN,
                                  longest=_APPROACH_MAX, growth=_APPROACH_GROWTH)
        if found is not None:
            return found
        raise LimitsError(f'no approach of up to {_APPROACH_MAX:g} s from {self.start} '
                                'keeps to the limits')
