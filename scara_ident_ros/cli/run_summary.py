"""The summary ``scara-ident run`` prints and writes as ``summary.json``, typed.

Made from the nodes' ``stats_file`` JSON (the identifier's is
:meth:`scara_ident_ros.identification.reports.MethodReport.as_dict`) and the bag; the
names are the reports' (``learnt``, ``skipped`` per reason with ``skipped_total``,
``validation_nmse`` per joint beside ``validation_nmse_total``).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from scara_ident_ros.identification.reports import SkipCounts

__all__ = ['JointStatesUse', 'MethodRow', 'RunSummary', 'StreamUse', 'stream_use']


@dataclass(frozen=True)
class StreamUse:
    """How a method used the published samples: ``predicted + skipped.total + lost +
    not_drained = published``.

    Attributes
    ----------
    processed, predicted : int or None
        Samples the identifier took and predicted (None: no stats file).
    skipped : SkipCounts
        Samples taken without a prediction, per reason.
    lost : int or None
        Samples lost before the identifier (stamp gaps).
    not_drained : int or None
        Published samples the identifier had not taken when it stopped.
    shortfall : int or None
        Published samples not predicted.
    """

    processed: int | None
    predicted: int | None
    skipped: SkipCounts
    lost: int | None
    not_drained: int | None
    shortfall: int | None


def stream_use(published: int | None, info: Mapping[str, Any]) -> StreamUse:
    """How a method used the ``published`` samples, from its identifier's statistics
    (the stats file's JSON)."""
    processed = info.get('processed')
    predicted = info.get('predicted')
    lost = info.get('lost')
    not_drained = shortfall = None
    if published is not None and processed is not None:
        not_drained = max(published - processed - (lost or 0), 0)
    if published is not None and predicted is not None:
        shortfall = published - predicted
    return StreamUse(processed, predicted, SkipCounts(dict(info.get('skipped') or {})),
                     lost, not_drained, shortfall)


@dataclass(frozen=True)
class MethodRow:
    """One method's line of the summary.

    Attributes
    ----------
    trainer : str or None
        The identifier's trainer.
    use : StreamUse
        How it used the published samples.
    learnt, held_out : int or None
        Samples learnt from and kept for validation.
    updates : int or None
        Weight updates of a learner beside the stream; ``updates_per_s`` their rate (1/s).
    mse_total, nmse_total : float or None
        Windowed errors at the end over all joints; ``mse``, ``nmse`` per joint.
    validation_nmse_total : float or None
        Held-out NMSE at the end over all joints; ``validation_nmse`` per joint.
    published : int or None
        Predictions the identifier published.
    recorded : int or None
        Predictions in the bag.
    model : str
        Where the method's model was saved.
    """

    trainer: str | None
    use: StreamUse
    learnt: int | None = None
    held_out: int | None = None
    updates: int | None = None
    updates_per_s: float | None = None
    mse_total: float | None = None
    nmse_total: float | None = None
    mse: list[float] | None = None
    nmse: list[float] | None = None
    validation_nmse_total: float | None = None
    validation_nmse: list[float] | None = None
    published: int | None = None
    recorded: int | None = None
    model: str = ''

    @classmethod
    def of(cls, info: Mapping[str, Any], published: int | None, recorded: int | None,
           model: str) -> MethodRow:
        """From an identifier's stats file (JSON) and the run's counts."""
        return cls(trainer=info.get('trainer'), use=stream_use(published, info),
                   learnt=info.get('learnt'), held_out=info.get('held_out'),
                   updates=info.get('updates'), updates_per_s=info.get('updates_per_s'),
                   mse_total=info.get('mse_total'), nmse_total=info.get('nmse_total'),
                   mse=info.get('mse'), nmse=info.get('nmse'),
                   validation_nmse_total=info.get('validation_nmse_total'),
                   validation_nmse=info.get('validation_nmse'),
                   published=info.get('predicted'), recorded=recorded, model=model)

    def as_dict(self) -> dict[str, Any]:
        """The row as JSON data: the stream use's figures inline, ``skipped`` per reason
        with ``skipped_total``."""
        use = self.use
        data: dict[str, Any] = {'trainer': self.trainer, 'processed': use.processed,
                                'predicted': use.predicted, 'skipped': use.skipped.as_dict(),
                                'skipped_total': use.skipped.total, 'lost': use.lost,
                                'not_drained': use.not_drained, 'shortfall': use.shortfall}
        data.update({f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                     if f.name not in ('trainer', 'use')})
        return data


@dataclass(frozen=True)
class JointStatesUse:
    """The ``/joint_states`` stream over the run: published and late (the simulator's
    counts), recorded (in the bag), lost (the recorder's estimate) and the most publishers
    seen on it (the recorder's)."""

    published: int | None
    late: int | None
    recorded: int | None
    lost: int | None
    publishers: int | None


@dataclass(frozen=True)
class RunSummary:
    """What a ``scara-ident run`` did: the bag, each process's exit code, the stream, the
    recorder's statistics as it wrote them, and a :class:`MethodRow` per method."""

    bag: str
    exit_codes: Mapping[str, int]
    joint_states: JointStatesUse
    recorder: Mapping[str, Any]
    methods: Mapping[str, MethodRow] = field(default_factory=dict)
    interrupted: bool = False

    def as_dict(self) -> dict[str, Any]:
        """The summary as JSON data (``summary.json``)."""
        return {'bag': self.bag, 'exit_codes': dict(self.exit_codes),
                'joint_states': dataclasses.asdict(self.joint_states),
                'recorder': dict(self.recorder),
                'methods': {name: row.as_dict() for name, row in self.methods.items()},
                'interrupted': self.interrupted}
