"""Validate one joint-state sample and bring it into the configured joint order.

A sample either passes every check and comes out as a :class:`Sample` in joint order, or is
rejected with a :class:`SkipReason`: a rejected sample never reaches the network or the
differentiator, and is a missing sample to them, not a reason to restart the estimate (the
one state it changes is the count of stamps far behind, which tells a restarted clock).

Real drivers differ from the simulator in two ways handled here:

- **Rates and jitter.** A ros2_control ``joint_state_broadcaster`` publishes at its
  controller's rate (125 Hz to 1 kHz), with jittered stamps and now and then a lost sample.
  What counts as a clock gap therefore scales with the observed sample period (the median
  of the last :data:`PERIOD_SAMPLES` intervals): more than ``max_gap_ns`` *and* more than
  :data:`GAP_PERIODS` periods.
- **Repeated samples.** Some drivers send their last state again under a new stamp when
  no new one is ready: a sample whose q, q' and effort all equal the last accepted one's
  is refused as ``REPEATED`` (learnt twice it would weigh double, and its stamp is not
  that of the state).
- **Missing effort.** A broadcaster fills NaN for a joint without an effort interface, and
  some drivers publish no effort at all. Unless the effort is required (``need_effort``),
  such a sample is accepted without effort (``Sample.effort`` None): it can be predicted,
  not learnt or scored.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.skip_reason import SkipReason

if TYPE_CHECKING:
    from scara_ident_ros.dynamics.joint_limits import JointLimits

__all__ = ['Bounds', 'FloatArrayLike', 'Sample', 'SampleCheck', 'DEFAULT_MAX_GAP_NS',
           'GAP_PERIODS', 'LIMIT_MARGIN', 'PERIOD_SAMPLES', 'RESTART_SAMPLES',
           'joint_bounds']

FloatArrayLike = Sequence[float] | NDArray[np.float64]
"""A message array: a list, an ``array.array('d')`` (what rclpy gives) or an ndarray."""

DEFAULT_MAX_GAP_NS = 20_000_000  # ns: 20 missed samples at 1 kHz (the node's ``max_gap``)
#: Fraction of a limit's range a sample may exceed it by (the node's ``limit_margin``)
LIMIT_MARGIN = 0.5
GAP_PERIODS = 5  # a gap is also longer than this many observed sample periods (4 lost)
#: A clock restarts (a bag played again, a simulator restarted) when this many consecutive
#: samples are stamped far behind the last accepted one; fewer are bad stamps, refused.
RESTART_SAMPLES = 3
PERIOD_SAMPLES = 15  # intervals whose median is the observed sample period


class Sample(NamedTuple):
    """One accepted sample, in the configured joint order.

    Attributes
    ----------
    stamp_ns : int
        Time of the sample (ns).
    position, velocity : ndarray of shape (n_joints,)
        q (rad or m) and q' (rad/s or m/s).
    effort : ndarray of shape (n_joints,) or None
        Measured effort (N·m or N); None if missing or NaN for some joint.
    gap : bool
        The clock jumped by more than the maximum gap since the previous accepted sample:
        the sample starts a new history (derivatives restart).
    """

    stamp_ns: int
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    effort: NDArray[np.float64] | None
    gap: bool


class Bounds(NamedTuple):
    """The values a sample may have, in joint order.

    Attributes
    ----------
    lo, hi : ndarray of shape (3, n_joints)
        Lowest and highest position (rad or m), velocity (rad/s or m/s) and effort (N·m or
        N) of each joint; ±inf where there is no bound.
    """

    lo: NDArray[np.float64]
    hi: NDArray[np.float64]

    @classmethod
    def from_limits(cls, position_min: NDArray[np.float64], position_max: NDArray[np.float64],
                    velocity_max: NDArray[np.float64], effort_max: NDArray[np.float64], *,
                    margin: float = LIMIT_MARGIN) -> Bounds:
        """Bounds ``margin`` (a fraction) beyond a robot's limits.

        Positions may leave ``[min, max]`` by ``margin`` times the range, velocities and
        efforts exceed their maxima by ``margin`` times them: values a working robot cannot
        report, however hard it is driven.
        """
        span = np.asarray(position_max, float) - np.asarray(position_min, float)
        vel = np.abs(np.asarray(velocity_max, float)) * (1.0 + margin)
        eff = np.abs(np.asarray(effort_max, float)) * (1.0 + margin)
        return cls(np.stack([np.asarray(position_min, float) - margin * span, -vel, -eff]),
                   np.stack([np.asarray(position_max, float) + margin * span, vel, eff]))


def joint_bounds(limits: JointLimits, margin: float) -> Bounds | None:
    """The values a sample may have, ``margin`` (a fraction) beyond ``limits``; None (no
    check) if ``margin`` is negative."""
    if margin < 0:
        return None
    return Bounds.from_limits(limits.position_min, limits.position_max, limits.velocity_max,
                              limits.effort_max, margin=margin)


class SampleCheck:
    """Checks of the stamp, the array lengths, the names and the values of each sample.

    Parameters
    ----------
    joint_map : JointMap
        The joint order; if it has none yet, the first valid sample's names are adopted.
    need_effort : bool
        Reject samples without effort (empty, or NaN for some joint) as ``NO_EFFORT``, for
        offline training; otherwise they are accepted with ``Sample.effort`` None.
    max_gap_ns : int
        A clock jump (ns) forwards larger than this and than :data:`GAP_PERIODS` observed
        periods (:attr:`period_ns`) marks a sample as ``gap``. A step backwards is rejected
        as ``STAMP_BACKWARDS``: one bad stamp must not restart the estimate. Only a jump
        back beyond a gap that :data:`RESTART_SAMPLES` consecutive samples confirm is a
        restarted clock: the last of them is accepted as ``gap``.
    bounds : Bounds, optional
        Reject finite values outside them as ``OUT_OF_LIMITS``; None checks none.

    Notes
    -----
    Checks run in this order, and the first that fails names the reason: stamp (repeated,
    backwards), presence (``NO_VELOCITY``, ``NO_POSITION``, ``NO_EFFORT``), lengths, names
    (see :meth:`JointMap.permutation`), finiteness, bounds, then ``REPEATED``: a sample with
    effort whose positions, velocities and efforts all equal the last accepted one's (a
    driver re-sending its last state under a new stamp). Stamps are compared with the last
    *accepted* sample only. The observed period is the median of the last
    :data:`PERIOD_SAMPLES` forward intervals between accepted samples, gaps included (a
    median is not moved by a few lost samples, and a slow stream still learns its period);
    until there are that many, a gap is ``max_gap_ns`` alone.
    """

    def __init__(self, joint_map: JointMap, *, need_effort: bool = True,
                 max_gap_ns: int = DEFAULT_MAX_GAP_NS, bounds: Bounds | None = None) -> None:
        if max_gap_ns <= 0:
            raise ValueError(f'max_gap_ns must be positive, got {max_gap_ns}')
        self.joint_map = joint_map
        self.bounds = bounds
        self.need_effort = need_effort
        self.max_gap_ns = int(max_gap_ns)
        self._last_stamp: int | None = None
        self._intervals: deque[int] = deque(maxlen=PERIOD_SAMPLES)  # ns, latest last
        self._period: int | None = None
        self._gap_ns = self.max_gap_ns
        self._behind: list[int] = []  # stamps far behind the last accepted, consecutive
        self._last_values: NDArray[np.float64] | None = None  # (2 or 3, n) of the last accepted

    @property
    def period_ns(self) -> int | None:
        """Observed sample period (ns): the median of the last :data:`PERIOD_SAMPLES`
        intervals; None until there are that many."""
        return self._period

    @property
    def gap_ns(self) -> int:
        """The longest interval (ns) that is not a gap: ``max_gap_ns`` or
        :data:`GAP_PERIODS` observed periods, whichever is longer."""
        return self._gap_ns

    @property
    def last_stamp_ns(self) -> int | None:
        """Stamp of the last accepted sample (ns), None before the first or after a reset."""
        return self._last_stamp

    def reset(self) -> None:
        """Forget the last stamp and the period: the next valid sample is accepted whatever
        its time."""
        self._last_stamp = None
        self._intervals.clear()
        self._period = None
        self._gap_ns = self.max_gap_ns
        self._behind.clear()
        self._last_values = None

    def check(self, stamp_ns: int, names: Sequence[str], position: FloatArrayLike,
              velocity: FloatArrayLike, effort: FloatArrayLike = ()) -> Sample | SkipReason:
        """Validate one sample: its stamp (ns), joint names, q (rad or m), q' (rad/s or
        m/s) and effort (N·m or N, may be empty), each (m,) in message order. Return the
        sample in joint order, or why it was rejected (then nothing changed)."""
        gap = False
        last = self._last_stamp
        dt = 0
        if last is not None:
            dt = stamp_ns - last
            if dt == 0:
                return SkipReason.STAMP_REPEATED
            if dt < 0 and (dt >= -self._gap_ns or not self._clock_restarted(stamp_ns)):
                return SkipReason.STAMP_BACKWARDS
            gap = dt > self._gap_ns or dt < 0
        m = len(names)
        if len(velocity) == 0:
            return SkipReason.NO_VELOCITY
        if len(position) == 0:
            return SkipReason.NO_POSITION
        has_effort = len(effort) != 0
        if not has_effort and self.need_effort:
            return SkipReason.NO_EFFORT
        if len(position) != m or len(velocity) != m or (has_effort and len(effort) != m):
            return SkipReason.LENGTH_MISMATCH
        perm = self.joint_map.permutation(names)
        if isinstance(perm, SkipReason):
            return perm
        raw = np.empty((3 if has_effort else 2, m))
        raw[0] = position
        raw[1] = velocity
        if has_effort:
            raw[2] = effort
        if not np.isfinite(raw).all():
            reason = _missing_effort(raw)
            if reason is not None or self.need_effort:
                return reason or SkipReason.NO_EFFORT
            raw, has_effort = raw[:2], False  # NaN effort: not measured for some joint
        values = raw[:, perm]
        bounds = self.bounds
        if bounds is not None:
            rows = values.shape[0]
            if (values < bounds.lo[:rows]).any() or (values > bounds.hi[:rows]).any():
                return SkipReason.OUT_OF_LIMITS
        last_values = self._last_values
        if has_effort and last_values is not None and np.array_equal(values, last_values):
            return SkipReason.REPEATED
        if self.joint_map.names is None:
            self.joint_map.adopt(names)
        self._last_stamp = stamp_ns
        self._last_values = values
        self._behind.clear()
        if dt > 0:
            self._observe(dt)
        return Sample(stamp_ns, values[0], values[1], values[2] if has_effort else None, gap)

    def _clock_restarted(self, stamp_ns: int) -> bool:
        """Whether a stamp far behind the last accepted one is a restarted clock (the
        :data:`RESTART_SAMPLES` th of consecutive stamps that go forwards among themselves,
        each within a gap of the previous one) rather than one bad stamp."""
        behind = self._behind
        if behind and 0 < stamp_ns - behind[-1] <= self._gap_ns:
            behind.append(stamp_ns)
        else:
            behind[:] = [stamp_ns]
        return len(behind) >= RESTART_SAMPLES

    def _observe(self, interval_ns: int) -> None:
        """Take one forward interval into the observed period and the gap threshold."""
        intervals = self._intervals
        intervals.append(interval_ns)
        if len(intervals) == PERIOD_SAMPLES:
            self._period = sorted(intervals)[PERIOD_SAMPLES // 2]
            self._gap_ns = max(self.max_gap_ns, GAP_PERIODS * self._period)


def _missing_effort(raw: NDArray[np.float64]) -> SkipReason | None:
    """Why a sample with a non-finite value (rows q, q'[, effort]) is refused: None if
    only effort entries are NaN (not measured), else ``NON_FINITE``."""
    if raw.shape[0] < 3 or not np.isfinite(raw[:2]).all():
        return SkipReason.NON_FINITE
    return SkipReason.NON_FINITE if np.isinf(raw[2]).any() else None
