"""The planned motion cut into the chunks a trajectory controller is sent, each stoppable.

A chunk holds the plan's samples every ``step`` s from a little before the time it is sent
to a horizon ahead, then a stop (:func:`~scara_ident_ros.excitation.stopping.plan_stop`)
to rest. The next chunk replaces it before its stop begins, so while chunks keep coming the
arm follows the plan; if they stop coming (the sender killed, the network down) the
controller plays the stop and holds the arm at rest, as ``joint_trajectory_controller``
holds a trajectory's last point. Every chunk ends at rest, which a controller with
``allow_nonzero_velocity_at_trajectory_end: false`` requires.

Two chunks give the same values at the times they share (both are the plan there), so
switching from one to the next anywhere in their overlap is continuous in q, q', q''.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.excitation.plan import ExcitationPlan
from scara_ident_ros.excitation.stopping import plan_stop

__all__ = ['Chunk', 'make_chunk']


@dataclass(frozen=True)
class Chunk:
    """Samples of the commanded motion, the last one at rest.

    Attributes
    ----------
    times : ndarray of shape (m,)
        Plan times (s), every ``step``.
    q, qd, qdd : ndarray of shape (m, n)
        Positions (rad, m), velocities and accelerations.
    stop_time : float
        Plan time at which its stop begins (s).
    rest_time : float
        Plan time of its last point, at rest (s).
    """

    times: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    stop_time: float
    rest_time: float

    def __len__(self) -> int:
        return int(self.times.size)


def make_chunk(plan: ExcitationPlan, first: float, stop_time: float, step: float,
               limits: JointLimits) -> Chunk:
    """The plan from ``first`` to ``stop_time``, then a stop to rest, every ``step`` s.

    ``first`` is rounded down and ``stop_time`` up to the grid of ``step`` (s); the stop
    keeps to ``limits``.
    """
    k_first = max(0, math.floor(round(first / step, 6)))
    k_stop = max(k_first, math.ceil(round(stop_time / step, 6)))
    stop = plan_stop(plan, k_stop * step, limits, step)
    k_rest = k_stop + round(stop.duration / step)
    on_plan = step * np.arange(k_first, k_stop + 1)
    stopping = step * np.arange(k_stop + 1, k_rest + 1)
    q_p, qd_p, qdd_p = plan.evaluate(on_plan)
    q_s, qd_s, qdd_s = stop.evaluate(stopping)
    return Chunk(np.concatenate([on_plan, stopping]), np.vstack([q_p, q_s]),
                 np.vstack([qd_p, qd_s]), np.vstack([qdd_p, qdd_s]),
                 k_stop * step, k_rest * step)
