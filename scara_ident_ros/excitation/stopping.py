"""Bringing the arm to rest smoothly from any time of the plan, along the planned path.

A stop at plan time t_s slows the plan's own clock down instead of leaving its path: the
commanded motion is q(t) = P(σ(t)), with P the plan and σ a time warp whose rate σ' falls
from 1 to 0 over the stop's duration T_s by the quintic smoothstep, τ = (t − t_s)/T_s:

    σ'(t)  = 1 − s(τ),   σ''(t) = −s'(τ) = −30 τ² (1 − τ)² / T_s
    σ(t)   = t_s + T_s (τ − 5/2 τ⁴ + 3 τ⁵ − τ⁶)          (σ(t_s + T_s) = t_s + T_s / 2)
    q'     = P'(σ) σ',   q'' = P''(σ) σ'² + P'(σ) σ''

At τ = 0, σ' = 1 and σ'' = 0, so q, q', q'' continue the plan's; at τ = 1 the arm is at
rest (σ' = 0) with q'' = 0 (σ'' = 0), half a stop's duration further along the path. The
positions are the plan's, so within its limits, and |q'| <= |P'|. The acceleration gains
P' σ'' while P'' σ'² shrinks: T_s is the shortest multiple of the point period, from a
geometric series (from 0.5 s), whose samples keep |q''| within the acceleration limits.
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from scara_ident_ros.dynamics.joint_limits import JointLimits, LimitsError
from scara_ident_ros.excitation.duration_search import shortest_duration
from scara_ident_ros.excitation.joint_sequence import Motion
from scara_ident_ros.excitation.plan import ExcitationPlan

__all__ = ['Stop', 'plan_stop']

_STOP_MIN = 0.5          # s, shortest stop tried (gentler on a real arm than the limits)
_STOP_MAX = 120.0        # s, longest stop tried
_STOP_GROWTH = 1.25      # ratio of two stop durations tried
_CHECK_PER_STEP = 5      # samples a stop is checked on per point period


class Stop:
    """The stop along ``plan`` starting at plan time ``start`` and lasting ``duration``.

    Parameters
    ----------
    plan : ExcitationPlan
        The planned motion P.
    start : float
        Plan time t_s at which the stop begins (s).
    duration : float
        T_s (s), > 0.
    """

    def __init__(self, plan: ExcitationPlan, start: float, duration: float) -> None:
        self.plan = plan
        self.start = float(start)
        self.duration = float(duration)

    @property
    def end(self) -> float:
        """Plan time at which the arm is at rest (s)."""
        return self.start + self.duration

    def evaluate(self, t: npt.ArrayLike) -> Motion:
        """Commanded q, q', q'' at plan times t (N,) >= start (s), each (N, n); at rest
        after :attr:`end`."""
        elapsed = np.asarray(t, dtype=float) - self.start
        # a time within a nanosecond of the end (rounding of k * step) is the end: at rest
        tau = np.where(elapsed >= self.duration - 1e-9, 1.0,
                       np.clip(elapsed / self.duration, 0.0, 1.0))
        sigma = self.start + self.duration * (tau - tau ** 4 * (2.5 + tau * (tau - 3.0)))
        rate = ((1.0 - tau) ** 3 * (1.0 + tau * (3.0 + 6.0 * tau)))[:, None]  # 1 - s: 0 at rest
        rate_change = (-30.0 * (tau * (1.0 - tau)) ** 2 / self.duration)[:, None]
        q, qd, qdd = self.plan.evaluate(sigma)
        return q, qd * rate, qdd * rate ** 2 + qd * rate_change


def plan_stop(plan: ExcitationPlan, start: float, limits: JointLimits,
              step: float) -> Stop:
    """The shortest stop from ``start`` keeping to the acceleration limits of ``limits``.

    It is checked on a grid five times finer than the points it is sent as, so that the
    controller's interpolation between the points keeps to the limits too.

    ``step`` (s) is the period of the points the stop is sent as; the duration is a multiple
    of it.

    Raises
    ------
    LimitsError
        If no stop of up to two minutes keeps to the acceleration limits (the plan itself
        would have to be outside them).
    """

    def keeps_to_limits(candidate: float) -> Stop | None:
        duration = math.ceil(round(candidate / step, 6)) * step
        stop = Stop(plan, start, duration)
        times = start + (step / _CHECK_PER_STEP) * np.arange(
            _CHECK_PER_STEP * round(duration / step) + 1)
        _, _, qdd = stop.evaluate(times)
        return stop if np.all(np.abs(qdd) <= limits.acceleration_max) else None

    found = shortest_duration(keeps_to_limits, shortest=_STOP_MIN, longest=_STOP_MAX,
                              growth=_STOP_GROWTH)
    if found is not None:
        return found
    raise LimitsError(f'no stop from plan time {start:g} s of up to {_STOP_MAX:g} s '
                            'keeps to the acceleration limits')
