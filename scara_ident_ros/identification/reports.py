"""What an identifier reports: typed, frozen, one name per figure.

Two kinds of report come out of an :class:`~scara_ident_ros.identification.session.
IdentificationSession`, one per method:

- :class:`MethodReport`: the counters and errors since start (or since the last
  ``~/reset``), with the stream's figures (:class:`StreamFigures`, from the node) and the
  learner's (:class:`LearningFigures`); the node's statistics log line and its
  ``stats_file`` JSON (:meth:`MethodReport.as_dict`) are made from it.
- :class:`HealthFigures`: what ``/diagnostics`` shows
  (:func:`scara_ident_ros.nodes.health.identifier_health` takes :meth:`HealthFigures.as_dict`
  as keywords).

Spelling and units, the same in every report, log line and JSON key: samples are
``learnt`` (never "learned"); ``skipped`` is always per reason (:class:`SkipCounts`, its
``total`` property the sum); a figure per joint is a list (``validation_nmse``) and its
value over all joints ends in ``_total`` (``validation_nmse_total``); times carry their
unit in the name (``_ms``, ``_s``); ``worst_lag_ms`` is the largest delay since start,
``period_worst_lag_ms`` the largest since the previous health report.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['ContactState', 'HealthFigures', 'LearningFigures', 'MethodReport', 'SkipCounts',
           'StreamFigures']


def _floats(values: Any) -> tuple[float, ...] | None:
    """A per-joint array (or None) as a tuple of floats."""
    return None if values is None else tuple(float(v) for v in values)


@dataclass(frozen=True)
class SkipCounts:
    """Samples that produced no prediction, per reason (``SkipReason`` values as keys,
    reasons with none left out).

    Attributes
    ----------
    by_reason : mapping of str to int
        Samples skipped per reason.
    """

    by_reason: Mapping[str, int] = field(default_factory=dict)

    @classmethod
    def of(cls, counts: Mapping[SkipReason, int]) -> SkipCounts:
        """From counters keyed by :class:`SkipReason` (as ``Counts.skipped``)."""
        return cls({reason.value: int(n) for reason, n in counts.items() if n})

    @property
    def total(self) -> int:
        """Samples skipped, all reasons together."""
        return sum(self.by_reason.values())

    def as_dict(self) -> dict[str, int]:
        """The counts per reason, for JSON."""
        return dict(self.by_reason)

    def __str__(self) -> str:
        return (', '.join(f'{reason} {n}' for reason, n in self.by_reason.items())
                or 'none')


@dataclass(frozen=True)
class StreamFigures:
    """Figures of the ``joint_states`` stream itself, measured by the node.

    Attributes
    ----------
    lost : int
        Samples estimated lost from stamp gaps (``nodes.health.LossCounter``).
    pauses : int
        Stamp jumps longer than ``max_gap`` (pauses, not losses).
    paused_s : float
        Their total length (s).
    path_delay_p50_ms, path_delay_p99_ms : float or None
        Delay from a sample's arrival to its prediction's publication (ms).
    wall_clock_stamps : bool or None
        Whether the stamps are on the wall clock (lags are then meaningful); None: not
        known yet.
    joint_states_publishers : int
        Most publishers seen on ``joint_states`` at once.
    stamps_backward : int
        Stamps that went back in time.
    """

    lost: int = 0
    pauses: int = 0
    paused_s: float = 0.0
    path_delay_p50_ms: float | None = None
    path_delay_p99_ms: float | None = None
    wall_clock_stamps: bool | None = None
    joint_states_publishers: int = 0
    stamps_backward: int = 0

    def as_dict(self) -> dict[str, Any]:
        """The figures by name, for JSON."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class LearningFigures:
    """How a learner beside the stream (a background process) progresses.

    Attributes
    ----------
    updates : int
        Weight updates taken from the learner.
    updates_per_s : float or None
        Their recent rate (1/s).
    lm_steps_taken : int
        Levenberg–Marquardt steps the learner has taken.
    learn_dropped : int
        Samples not learnt because the learner was behind.
    """

    updates: int
    updates_per_s: float | None
    lm_steps_taken: int
    learn_dropped: int

    def as_dict(self) -> dict[str, Any]:
        """The figures by name, for JSON."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class MethodReport:
    """One method's counters and errors since start (or the last ``~/reset``).

    ``processed == predicted + skipped.total + pending``; while learning, ``predicted ==
    learnt + held_out + refused + no_effort``. Before the first valid sample (no model
    yet) only ``method``, ``processed`` and ``skipped`` are filled in.

    Attributes
    ----------
    method : str
        The method's name (``ffs``, ``hybrid``, ...).
    trainer : str
        The trainer's name ('' before a model exists).
    joint_names : tuple of str
        The identified joints, in the order of the per-joint figures.
    processed, predicted, learnt, held_out, refused, clipped, no_effort, pending : int
        Samples taken, predicted, learnt from, kept for validation, whose step the trainer
        refused, whose prediction was clipped to the effort bounds, predicted without an
        effort, and accepted but not yet complete (the acceleration estimate's lag).
    skipped : SkipCounts
        Samples without a prediction, per reason.
    mse, nmse : tuple of float, shape (n_joints,), or None
        Windowed prequential errors per joint ((N·m)² or N²; NMSE: relative to the variance).
    mse_total, nmse_total : float or None
        The same over all joints.
    validation_nmse : tuple of float, shape (n_joints,), or None
        Held-out NMSE per joint; None before any held-out sample.
    validation_nmse_total : float or None
        Held-out NMSE over all joints.
    contacts : int
        Samples with a joint over its contact threshold.
    contact_armed : bool
        Whether contact detection is armed.
    contact_thresholds : tuple of float, shape (n_joints,), or None
        Contact thresholds (N·m or N), None until calibrated.
    contact_held : int
        Samples not checked for contact: outside the calibrated envelope.
    contact_delay_p50_ms, contact_delay_p99_ms : float or None
        Contact decisions' delay from the sample's stamp (ms).
    worst_lag_ms : float
        Largest delay from a sample's stamp to its prediction since start (ms).
    lag_p50_ms, lag_p99_ms : float or None
        Percentiles of that delay (ms, upper edges of 1 ms bins).
    stream : StreamFigures or None
        The stream's figures (the node's; None from a session without a node).
    learning : LearningFigures or None
        A background learner's progress (None for a trainer in the message path).
    previous : tuple of MethodReport
        The reports from before each ``~/reset``, oldest first.
    """

    method: str
    processed: int = 0
    skipped: SkipCounts = field(default_factory=SkipCounts)
    trainer: str = ''
    joint_names: tuple[str, ...] = ()
    predicted: int = 0
    learnt: int = 0
    held_out: int = 0
    refused: int = 0
    clipped: int = 0
    no_effort: int = 0
    pending: int = 0
    mse: tuple[float, ...] | None = None
    nmse: tuple[float, ...] | None = None
    mse_total: float | None = None
    nmse_total: float | None = None
    validation_nmse: tuple[float, ...] | None = None
    validation_nmse_total: float | None = None
    contacts: int = 0
    contact_armed: bool = False
    contact_thresholds: tuple[float, ...] | None = None
    contact_held: int = 0
    contact_delay_p50_ms: float | None = None
    contact_delay_p99_ms: float | None = None
    worst_lag_ms: float = 0.0
    lag_p50_ms: float | None = None
    lag_p99_ms: float | None = None
    stream: StreamFigures | None = None
    learning: LearningFigures | None = None
    previous: tuple[MethodReport, ...] = ()

    @staticmethod
    def per_joint(values: Any) -> tuple[float, ...] | None:
        """A per-joint array (or None) as the tuple a report holds."""
        return _floats(values)

    def as_dict(self) -> dict[str, Any]:
        """The report as JSON data (the node's ``stats_file``): the fields by name, per-joint
        figures as lists, ``skipped`` per reason with ``skipped_total`` beside it, the
        stream's and the learner's figures inline, ``previous`` only after a reset."""
        data: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in ('stream', 'learning', 'previous'):
                continue
            if f.name == 'skipped':
                data['skipped'] = value.as_dict()
                data['skipped_total'] = value.total
            elif isinstance(value, tuple):
                data[f.name] = list(value)
            else:
                data[f.name] = value
        for part in (self.stream, self.learning):
            if part is not None:
                data.update(part.as_dict())
        if self.previous:
            data['previous'] = [before.as_dict() for before in self.previous]
        return data


@dataclass(frozen=True)
class ContactState:
    """Contact detection's state for ``/diagnostics``.

    Attributes
    ----------
    armed : bool
        Whether detection is armed.
    why_not : str
        Why it is not armed ('' when armed).
    thresholds : tuple of float, shape (n_joints,), or None
        Per-joint thresholds on |measured − predicted − its median| (N·m or N).
    false_alarms_per_hour : float or None
        The false-alarm rate the held-out residuals' tail gives at the thresholds.
    segments : float or None
        Independent held-out segments the thresholds come from.
    held : int
        Samples not checked (since start): outside the calibrated envelope.
    delay_p50_ms, delay_p99_ms : float or None
        The decision's delay from the sample's stamp since the previous report (ms).
    """

    armed: bool = False
    why_not: str = ''
    thresholds: tuple[float, ...] | None = None
    false_alarms_per_hour: float | None = None
    segments: float | None = None
    held: int = 0
    delay_p50_ms: float | None = None
    delay_p99_ms: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """``identifier_health``'s ``contact_*`` keywords."""
        return {f'contact_{f.name}': getattr(self, f.name) for f in dataclasses.fields(self)}


@dataclass(frozen=True)
class HealthFigures:
    """A method's figures for ``/diagnostics`` (the stream's counters are the node's).

    Attributes
    ----------
    processed, learnt : int
        Samples taken and learnt from since start.
    skipped : SkipCounts
        Samples without a prediction since start, per reason.
    period_worst_lag_ms : float or None
        Largest delay from a sample's stamp to its prediction since the previous health
        report (ms); None: no prediction in the period.
    error_finite : bool
        Whether the windowed prediction error is finite.
    validation_nmse_total : float or None
        Held-out NMSE over all joints.
    learning : bool
        Whether the identifier learns (``learn``).
    update_rate : float or None
        Weight updates/s of a learner beside the stream.
    update_overdue_s : float or None
        Seconds such a learner's due update has waited.
    contact : ContactState
        Contact detection's state.
    contact_arm_nmse : float or None
        The held-out NMSE below which contact detection arms.
    """

    processed: int
    learnt: int
    skipped: SkipCounts
    period_worst_lag_ms: float | None
    error_finite: bool
    validation_nmse_total: float | None
    learning: bool
    update_rate: float | None = None
    update_overdue_s: float | None = None
    contact: ContactState = field(default_factory=ContactState)
    contact_arm_nmse: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """The keywords of ``identifier_health``: the figures by name, ``skipped_total``
        for ``skipped`` and the contact state inline."""
        data = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if f.name not in ('skipped', 'contact')}
        data['skipped_total'] = self.skipped.total
        data.update(self.contact.as_dict())
        return data

