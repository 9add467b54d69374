"""What the identifier and its learner processes say to each other: typed messages.

A learner process (:mod:`~scara_ident_ros.identification.lm_process` for the ``lm`` trainer,
:mod:`~scara_ident_ros.identification.estimator_process` for the learners' ``partial_fit``)
first receives its start message (:class:`LmStart`, :class:`EstimatorStart`), answers
:class:`Ready`, then receives :class:`Samples` (and :class:`Schedule`) until :class:`Stop`.
It answers each update: :class:`LmUpdate` (the ``lm`` trainer: new weights or none, a
hybrid's bounds and gate) or :class:`LearnerState` (an estimator's state as arrays), and,
the ``lm`` learner, :class:`Stopped` when it ends. The messages are pickled through a pipe
(:mod:`~scara_ident_ros.identification.learner_process`); a :class:`Samples` message is
written in one atomic write, so it stays below ``PIPE_BUF`` bytes.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from scara_ident_ros.identification.learner_settings import LearnerSettings
    from scara_ident_ros.identification.streamed_estimator import ArrayLearner
    from scara_ident_ros.nn import FeedForwardNet

__all__ = ['EstimatorStart', 'HybridState', 'LearnerState', 'LmStart', 'LmUpdate', 'Ready',
           'Samples', 'Schedule', 'Stop', 'Stopped']

FloatArray = NDArray[np.float64]


# ---------------------------------------------------------------- to the learner
@dataclass(frozen=True)
class LmStart:
    """The ``lm`` learner's network (its weights and scaling) and settings; ``physical``: a
    hybrid's physical model (``PhysicalModel.to_arrays``), whose residual the network learns."""

    model: FeedForwardNet
    settings: LearnerSettings
    physical: dict[str, np.ndarray] | None = None


@dataclass(frozen=True)
class EstimatorStart:
    """The learner to learn and how: ``partial_fit`` on at least ``batch`` samples (the first
    call ``warmup``); ``reservoir_size``/``seed`` of the reservoir a fresh learner is refitted
    on."""

    learner: ArrayLearner
    batch: int
    warmup: int
    reservoir_size: int
    seed: int
    nice: int  # the process's niceness
    label: str  # names the process (ps, top)


@dataclass(frozen=True)
class Samples:
    """Learnt samples, rows [x (3n), y (n)] of shape (N, 4n); ``theta`` (p,): a hybrid's
    physical parameters of the moment, whose residual they are learnt on."""

    rows: FloatArray
    theta: FloatArray | None = None


@dataclass(frozen=True)
class Schedule:
    """The ``lm`` learner's least new samples between updates and steps per update, from now."""

    lm_interval: int
    lm_steps: int


@dataclass(frozen=True)
class Stop:
    """Learn what has come, answer once more, end."""


# ---------------------------------------------------------------- from the learner
@dataclass(frozen=True)
class Ready:
    """The learner has started and waits for samples (its first answer)."""


@dataclass(frozen=True)
class HybridState:
    """A hybrid's correction as the ``lm`` learner left it: ``bounds`` (low, high) (n,) each
    or None, its updates ``undone`` by the check, the per-joint ``gate`` (n,), the ``region``
    its correction fades outside (``DataRegion.to_arrays``; None: none yet)."""

    bounds: tuple[FloatArray, FloatArray] | None
    undone: int
    gate: FloatArray
    region: dict[str, FloatArray] | None = None


@dataclass(frozen=True)
class LmUpdate:
    """An ``lm`` update has finished: ``theta`` the new weights, or None if they did not
    change (too few validation samples, or undone); ``steps`` LM steps taken in all;
    ``hybrid`` a hybrid's correction (None for a network alone)."""

    theta: FloatArray | None
    steps: int
    hybrid: HybridState | None = None


@dataclass(frozen=True)
class Stopped:
    """The ``lm`` learner has ended after ``steps`` LM steps."""

    steps: int


@dataclass(frozen=True)
class LearnerState:
    """An estimator's state after ``learnt`` samples in ``calls`` ``partial_fit`` calls
    (``seconds`` spent in them); ``arrays`` None while it has learnt nothing; ``last``:
    its final state (after :class:`Stop`)."""

    arrays: dict[str, np.ndarray] | None
    learnt: int
    calls: int
    seconds: float
    last: bool = False
