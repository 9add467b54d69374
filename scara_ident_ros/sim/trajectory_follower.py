"""The desired motion of an external trajectory command, as ``joint_trajectory_controller``
samples it: the simulator's ``trajectory:=external``.

A command is a ``trajectory_msgs/JointTrajectory`` in numbers: joint names, a start time
(``header.stamp``; None = when it is received) and points at times from that start, each
with positions and optionally velocities and accelerations. As the controller does
(ros2_controllers' ``Trajectory::sample``, spline interpolation):

- a new command replaces the current one when it is received; the desired state at that
  moment (position, velocity, acceleration) is its "state before the trajectory";
- before the first point's time, the motion goes from that state to the first point;
  between two points, it is the quintic polynomial matching both points' q, q', q''
  (cubic when the points have no accelerations, linear when they have positions only);
- after the last point, the last position is held at rest.

Before any command, the initial position is held at rest. A command with other joints
than the follower's, no points, times not increasing, values not finite or a start time
whose last point is already past is refused with the reason; the current one goes on.
The controller uses the measured state (or, with ``open_loop_control``, the last command)
as the state before a trajectory; here it is the last command, which the simulator's
computed-torque loop tracks closely.
"""
from __future__ import annotations

import bisect
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

__all__ = ['TrajectoryFollower']

NS_PER_S = 1_000_000_000
_Point = tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]


class TrajectoryFollower:
    """Desired q, q', q'' of n joints from the latest trajectory command.

    Parameters
    ----------
    joint_names : sequence of str
        The joints, in the order of the desired state.
    hold : ndarray of shape (n,)
        Position held at rest before any command (rad or m).

    Attributes
    ----------
    received, refused : int
        Commands taken and refused so far.
    """

    #: The simulator evaluates this trajectory one sample at a time (it changes while the
    #: simulation runs), not in batches ahead.
    batch_samples = 1

    def __init__(self, joint_names: Sequence[str], hold: NDArray[np.float64]) -> None:
        self.joint_names = tuple(joint_names)
        n = len(self.joint_names)
        rest = tuple(float(x) for x in hold)
        if len(rest) != n:
            raise ValueError(f'hold must have {n} positions, got {len(rest)}')
        self._n = n
        self._times: list[int] = [0]                    # ns, absolute, of every point
        self._points: list[_Point] = [(rest, (0.0,) * n, (0.0,) * n)]
        self._has_velocity = self._has_acceleration = True
        self.received = 0
        self.refused = 0

    def command(self, names: Sequence[str], start_ns: int | None, times_ns: Sequence[int],
                positions: Sequence[Sequence[float]],
                velocities: Sequence[Sequence[float]] | None,
                accelerations: Sequence[Sequence[float]] | None, now_ns: int) -> str | None:
        """Take a new command received at ``now_ns``; return why it is refused, or None.

        Parameters
        ----------
        names : sequence of str
            Joint names of the command's columns (any order).
        start_ns : int or None
            Absolute start time (ns), None (``header.stamp`` zero) to start at ``now_ns``.
        times_ns : sequence of int, length m
            ``time_from_start`` of each point (ns).
        positions : sequence of m sequences of n float
            Positions (rad or m).
        velocities, accelerations : sequence of m sequences of n float, or None
            Velocities and accelerations, None when the points have none.
        now_ns : int
            Time of receipt (ns), in the time base of ``start_ns`` and of :meth:`evaluate`.
        """
        reason = self._take(names, start_ns, times_ns, positions, velocities, accelerations,
                            now_ns)
        if reason is None:
            self.received += 1
        else:
            self.refused += 1
        return reason

    def _take(self, names: Sequence[str], start_ns: int | None, times_ns: Sequence[int],
              positions: Sequence[Sequence[float]],
              velocities: Sequence[Sequence[float]] | None,
              accelerations: Sequence[Sequence[float]] | None, now_ns: int) -> str | None:
        """:meth:`command` without the counting."""
        if sorted(names) != sorted(self.joint_names) or len(set(names)) != len(names):
            return f'joints {list(names)} are not {list(self.joint_names)}'
        m = len(times_ns)
        if m == 0:
            return 'no points'
        columns = [list(names).index(name) for name in self.joint_names]
        arrays: list[NDArray[np.float64] | None] = []
        for label, values in (('positions', positions), ('velocities', velocities),
                              ('accelerations', accelerations)):
            if values is None:
                arrays.append(None)
                continue
            array = np.asarray(values, dtype=float)
            if array.shape != (m, self._n):
                return f'{label} must be {m} x {self._n}, got {array.shape}'
            if not np.all(np.isfinite(array)):
                return f'{label} not finite'
            arrays.append(array[:, columns])
        if np.any(np.diff(np.asarray(times_ns, dtype=np.int64)) <= 0):
            return 'time_from_start must increase from point to point'
        start = now_ns if start_ns is None else start_ns
        if start + int(times_ns[-1]) < now_ns:
            return 'the trajectory ends before it was received'
        before = self._at(now_ns)
        q, qd, qdd = arrays
        zeros = (0.0,) * self._n
        self._has_velocity = qd is not None
        self._has_acceleration = qd is not None and qdd is not None
        points: list[_Point] = [before]
        for i in range(m):
            points.append((tuple(q[i].tolist()) if q is not None else zeros,
                           tuple(qd[i].tolist()) if qd is not None else zeros,
                           tuple(qdd[i].tolist()) if qdd is not None else zeros))
        first = start + int(times_ns[0])
        if first <= now_ns:  # already running: no segment from the state before
            points.pop(0)
            self._times = [start + int(t) for t in times_ns]
        else:
            self._times = [now_ns] + [start + int(t) for t in times_ns]
        self._points = points
        return None

    def evaluate(self, t: npt.ArrayLike
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Desired q, q', q'' at time(s) t (s, in the commands' time base).

        Returns three ndarray of shape (n,) for a scalar t, (N, n) for an array.
        """
        times = np.asarray(t, dtype=float)
        rows = [self._at(round(float(x) * NS_PER_S)) for x in np.atleast_1d(times)]
        q, qd, qdd = (np.array([row[i] for row in rows], dtype=float) for i in range(3))
        if times.ndim == 0:
            return q[0], qd[0], qdd[0]
        return q, qd, qdd

    def _at(self, t_ns: int) -> _Point:
        """Desired (q, q', q'') at ``t_ns``, as tuples of floats."""
        times = self._times
        i = bisect.bisect_right(times, t_ns)
        if i >= len(times):  # after the last point: hold it at rest
            zeros = (0.0,) * self._n
            return self._points[-1][0], zeros, zeros
        if i == 0:           # before the first point (a command from the past): start it
            return self._points[0]
        t0, t1 = times[i - 1], times[i]
        return _interpolate(self._points[i - 1], self._points[i], (t_ns - t0) * 1e-9,
                            (t1 - t0) * 1e-9, self._has_velocity, self._has_acceleration)


def _interpolate(a: _Point, b: _Point, t: float, duration: float, velocity: bool,
                 acceleration: bool) -> _Point:
    """q, q', q'' at t (s) into the segment of ``duration`` (s) from point a to point b:
    quintic with both accelerations, cubic with velocities only, else linear."""
    q, qd, qdd = [], [], []
    T = duration
    for j in range(len(a[0])):
        p0, v0, a0 = a[0][j], a[1][j], a[2][j]
        p1, v1, a1 = b[0][j], b[1][j], b[2][j]
        if acceleration:
            c3 = (20.0 * (p1 - p0) - (8.0 * v1 + 12.0 * v0) * T - (3.0 * a0 - a1) * T * T) / (
                2.0 * T ** 3)
            c4 = (30.0 * (p0 - p1) + (14.0 * v1 + 16.0 * v0) * T + (3.0 * a0 - 2.0 * a1) * T * T
                  ) / (2.0 * T ** 4)
            c5 = (12.0 * (p1 - p0) - 6.0 * (v1 + v0) * T - (a0 - a1) * T * T) / (2.0 * T ** 5)
            c2 = 0.5 * a0
        elif velocity:
            c2 = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * T) / T ** 2
            c3 = (2.0 * (p0 - p1) + (v0 + v1) * T) / T ** 3
            c4 = c5 = 0.0
        else:
            v0 = (p1 - p0) / T
            c2 = c3 = c4 = c5 = 0.0
        q.append(p0 + t * (v0 + t * (c2 + t * (c3 + t * (c4 + t * c5)))))
        qd.append(v0 + t * (2.0 * c2 + t * (3.0 * c3 + t * (4.0 * c4 + t * 5.0 * c5))))
        qdd.append(2.0 * c2 + t * (6.0 * c3 + t * (12.0 * c4 + t * 20.0 * c5)))
    return tuple(q), tuple(qd), tuple(qdd)
