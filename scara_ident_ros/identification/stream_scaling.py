"""The network's scaling for joints whose files lack some limits: from the stream's start.

A URDF gives position, velocity and effort limits but no acceleration limit, and nothing for
a continuous joint (or one without ``<limit>``). So that a URDF alone makes an identifier
predict, :class:`StreamScaling` takes what is missing from the first
:data:`SCALING_SPAN_S` of the stream, as ``scara-ident train`` does from a whole recording:

- acceleration: :data:`MARGIN` × the largest |q''| seen (q'' estimated as the identifier
  estimates it), at least ``velocity_max`` / :data:`ACCELERATION_TIME_S`: an arm standing
  still at the start must not get a range of its sensor noise, and arms reach full speed
  in a fraction of a second (the Barrett WAM recording, ``../shared/realdata``: its largest
  |q''| is 6 to 11 times its largest |q'|; twice its first second's largest |q''| covers
  the whole recording's on 6 of 7 joints);
- a joint without URDF limits: position range :data:`MARGIN` × the range seen about its
  middle, at least ± :data:`POSITION_HALF_RANGE`; velocity and effort :data:`MARGIN` × the
  largest seen, at least :data:`FLOOR` (1 rad/s, 1 N·m, or the unit of a prismatic joint).

The scaling is fixed once set: it is the network's, and learning changes it no more. Samples
outside it are still predicted: the scaling is affine and clips nothing, so the network sees
inputs beyond [-1, 1] and extrapolates (finite: its hidden units saturate or grow
logarithmically). Only the limits the robot's files give bound the samples
(``limit_margin``); estimated ones do not.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from scara_ident_ros.dynamics.joint_limits import LIMIT_NAMES, JointLimits
from scara_ident_ros.dynamics.urdf_limits import UrdfLimits
from scara_ident_ros.identification.differentiator import AccelerationEstimate
from scara_ident_ros.identification.input_stage import Input, InputStage
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.sample_check import Bounds, FloatArrayLike
from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['ACCELERATION_TIME_S', 'FLOOR', 'MARGIN', 'POSITION_HALF_RANGE', 'SCALING_SPAN_S',
           'StreamScaling', 'stream_joints']

SCALING_SPAN_S = 1.0  # s of stream stamps the missing limits are estimated from
MARGIN = 2.0  # estimated limit = MARGIN x the largest value seen
ACCELERATION_TIME_S = 0.2  # s: an acceleration limit is at least velocity_max / this
POSITION_HALF_RANGE = np.pi  # rad (m): least half range of a joint without position limits
FLOOR = 1.0  # least estimated velocity (rad/s, m/s) and effort (N·m, N)
_GAP_NS = 20_000_000  # ns: the identifier's default max_gap


def stream_joints(limits: JointLimits, urdf: UrdfLimits | None,
                  names: Sequence[str]) -> tuple[list[str], list[str]]:
    """The joints of ``names`` whose limits the stream must complete, and those that no
    file knows (really unknown: a stream cannot say what they are)."""
    lacking = limits.missing(names)
    known = () if urdf is None else (*urdf.names, *urdf.unlimited)
    return ([name for name in lacking if name in known],
            [name for name in lacking if name not in known])


class StreamScaling:
    """Estimate the limits the files lack from the first samples of ``names``.

    Parameters
    ----------
    limits : JointLimits
        Complete limits the files give (robot YAML, explicit parameters, URDF with
        acceleration limits); used as they are.
    urdf : UrdfLimits or None
        The URDF's limits: position, velocity and effort of its limited joints; its
        ``unlimited`` joints get all theirs from the stream.
    names : sequence of str
        The joints, in the identifier's order; each known to ``limits`` or ``urdf``.
    differentiator : AccelerationEstimate
        A fresh q'' estimate like the identifier's (this one's own).
    max_gap_ns : int
        As the identifier's ``max_gap`` (ns).
    derive_velocity : bool
        As the identifier's ``derive_velocity`` (``auto``: True).
    """

    def __init__(self, limits: JointLimits, urdf: UrdfLimits | None, names: Sequence[str],
                 differentiator: AccelerationEstimate, *, max_gap_ns: int = _GAP_NS,
                 derive_velocity: bool = False) -> None:
        self.names = tuple(names)
        lacking, unknown = stream_joints(limits, urdf, self.names)
        if unknown:
            raise ValueError(f'no limits anywhere for {unknown}')
        self.files, self.urdf, self.lacking = limits, urdf, lacking
        self.stage = InputStage(JointMap(self.names), need_effort=False,
                                max_gap_ns=max_gap_ns, differentiator=differentiator,
                                derive_velocity=derive_velocity)
        n = len(self.names)
        self.first_ns: int | None = None
        self.last_ns = 0
        self.samples = 0
        self.estimates = 0  # samples with a q'' estimate
        self._low = np.full(n, np.inf)
        self._high = np.full(n, -np.inf)
        self._peak = np.zeros((3, n))  # largest |q'|, |q''|, |effort| seen

    @property
    def ready(self) -> bool:
        """Whether :data:`SCALING_SPAN_S` of stamps are in, and some q'' estimate."""
        return (self.first_ns is not None and self.estimates > 0
                and self.last_ns - self.first_ns >= SCALING_SPAN_S * 1e9)

    def add(self, stamp_ns: int, names: Sequence[str], position: FloatArrayLike,
            velocity: FloatArrayLike, effort: FloatArrayLike = ()) -> SkipReason | None:
        """Take a sample (as :meth:`InputStage.push`); return why it is refused, or None."""
        reason, inputs = self.stage.push(stamp_ns, tuple(names), position, velocity, effort)
        if reason is not None and reason not in (SkipReason.WARMING_UP, SkipReason.GAP):
            return reason  # refused (GAP, WARMING_UP: taken, no q'' estimate yet)
        if self.first_ns is None:
            self.first_ns = stamp_ns
        self.last_ns, self.samples = stamp_ns, self.samples + 1
        self._observe(inputs)
        return None

    def _observe(self, inputs: Sequence[Input]) -> None:
        n = len(self.names)
        for item in inputs:
            x = item.x
            self._low = np.minimum(self._low, x[:n])
            self._high = np.maximum(self._high, x[:n])
            self._peak[0] = np.maximum(self._peak[0], np.abs(x[n:2 * n]))
            self._peak[1] = np.maximum(self._peak[1], np.abs(x[2 * n:]))
            effort = item.effort
            if effort is not None:
                self._peak[2] = np.maximum(self._peak[2], np.abs(effort))
            self.estimates += 1

    def limits(self) -> JointLimits:
        """The limits of :attr:`names`: the files' where they have them, else estimated
        from the samples so far (the history still pending is let out first)."""
        self._observe(self.stage.flush())
        values = {key: np.empty(len(self.names)) for key in LIMIT_NAMES}
        for j, name in enumerate(self.names):
            row = self._row(j, name)
            for key in LIMIT_NAMES:
                values[key][j] = row[key]
        return JointLimits.of(self.names, values, source=self.describe())

    def _row(self, j: int, name: str) -> dict[str, float]:
        """One joint's limits (module docstring)."""
        if name in self.files.names:
            k = self.files.names.index(name)
            return {key: float(getattr(self.files, key)[k]) for key in LIMIT_NAMES}
        velocity, acceleration, effort = MARGIN * self._peak[:, j]
        if self.urdf is not None and name in self.urdf.names:
            k = self.urdf.names.index(name)
            row = {'position_min': float(self.urdf.position_min[k]),
                   'position_max': float(self.urdf.position_max[k]),
                   'velocity_max': float(self.urdf.velocity_max[k]),
                   'effort_max': float(self.urdf.effort_max[k])}
        else:
            seen = bool(np.isfinite(self._low[j]))
            middle = 0.5 * (self._low[j] + self._high[j]) if seen else 0.0
            half = max(MARGIN * 0.5 * (self._high[j] - self._low[j]) if seen else 0.0,
                       POSITION_HALF_RANGE)
            row = {'position_min': middle - half, 'position_max': middle + half,
                   'velocity_max': max(velocity, FLOOR), 'effort_max': max(effort, FLOOR)}
        row['acceleration_max'] = max(acceleration, row['velocity_max'] / ACCELERATION_TIME_S)
        return row

    def bounds(self, margin: float) -> Bounds | None:
        """The sample bounds of the identifier's ``limit_margin``: the files' limits only
        (a URDF's position, velocity and effort), none where they were estimated."""
        if margin < 0:
            return None
        limits = self.limits()
        bounds = Bounds.from_limits(limits.position_min, limits.position_max,
                                    limits.velocity_max, limits.effort_max, margin=margin)
        urdf = self.urdf.names if self.urdf is not None else ()
        for j, name in enumerate(self.names):
            if name not in self.files.names and name not in urdf:
                bounds.lo[:, j], bounds.hi[:, j] = -np.inf, np.inf
        return bounds

    def describe(self) -> str:
        """Which limits are whose, in one line: each group of joints (named when there are
        several groups) and where its limits come from, then the estimated accelerations."""
        urdf = self.urdf.names if self.urdf is not None else ()
        groups = [([name for name in self.names if name in self.files.names],
                   f'all from {self.files.source}'),
                  ([name for name in self.lacking if name in urdf],
                   f'position, velocity, effort from {getattr(self.urdf, "source", "")}, '
                   f'acceleration from the stream'),
                  ([name for name in self.lacking if name not in urdf],
                   'all from the stream (no URDF limits: position range at least '
                   f'+-{POSITION_HALF_RANGE:.3g}, velocity and effort at least {FLOOR:g})')]
        groups = [(names, text) for names, text in groups if names]
        parts = [text if len(groups) == 1 else f'{names}: {text}' for names, text in groups]
        if self.lacking:
            span = 0.0 if self.first_ns is None else (self.last_ns - self.first_ns) / 1e9
            rows = [self._row(self.names.index(name), name) for name in self.lacking]
            parts.append(f"the stream's first {span:.2f} s ({self.samples} samples), "
                         f"{MARGIN:g} x the largest |q''| seen, at least velocity_max / "
                         f'{ACCELERATION_TIME_S:g} s, gives acceleration_max ' + ', '.join(
                             f'{row["acceleration_max"]:.3g}' for row in rows)
                         + ' (fixed from now on; faster motion is still predicted)')
        return '; '.join(parts)
