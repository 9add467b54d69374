"""Online identification of the inverse dynamics, one joint-state sample at a time.

Per sample: the :class:`InputStage` validates it and estimates q'' → the model predicts the
effort from x = [q, q', q''] → the error is recorded → the trainer learns from the sample,
unless a :class:`Holdout` keeps it for validation. The prediction precedes learning, so the
recorded error is an a-priori (one-step generalisation) error, not a training error.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.estimator import Estimator
from scara_ident_ros.identification.error_window import MSE_WINDOW, PAPER_WINDOW, ErrorWindow
from scara_ident_ros.identification.metrics import ErrorStats
from scara_ident_ros.identification.holdout import Holdout
from scara_ident_ros.identification.differentiator import AccelerationEstimate
from scara_ident_ros.identification.input_stage import Input, InputStage
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.sample_check import (DEFAULT_MAX_GAP_NS, Bounds,
                                                         FloatArrayLike)
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.identification.trainer import BackPropagation, Trainer

__all__ = ['StepResult', 'Counts', 'OnlineIdentifier']


class Polled(Protocol):
    """A learner beside the stream whose finished updates the model takes when polled
    (:class:`~scara_ident_ros.identification.learner_process.LearnerClient`)."""

    def poll(self) -> bool:
        """Take a finished update, if any; return whether the model changed."""


@dataclass(frozen=True, slots=True)
class StepResult:
    """Outcome of one sample.

    Attributes
    ----------
    stamp_ns : int
        The sample's stamp (ns).
    effort : ndarray of shape (n_joints,) or None
        A-priori predicted effort (N·m or N) in joint order; None if rejected.
    reason : SkipReason or None
        Why the sample was rejected.
    held_out : bool
        A validation sample: predicted, never learnt.
    measured : ndarray of shape (n_joints,) or None
        Measured effort (N·m or N) in joint order, if any: ``measured − effort`` is what
        the model does not explain (a contact's).
    """

    stamp_ns: int
    effort: NDArray[np.float64] | None
    reason: SkipReason | None = None
    held_out: bool = False
    measured: NDArray[np.float64] | None = None


@dataclass
class Counts:
    """Counters of an :class:`OnlineIdentifier`.

    ``processed == predicted + sum(skipped.values()) + pending`` always holds, and
    ``predicted == learnt + held_out + refused + no_effort`` while learning.

    Attributes
    ----------
    processed, predicted, learnt, held_out : int
        Samples passed in, predicted, learnt from, kept for validation.
    refused : int
        Predicted, not learnt: the trainer refused the step (weights unchanged).
    no_effort : int
        Predicted without a measured effort (empty, or NaN for some joint): neither learnt
        nor scored.
    clipped : int
        Predictions clipped to the effort bounds.
    skipped : dict of SkipReason to int
        Samples without a prediction, per reason (every reason present).
    pending : int
        Accepted samples whose input is not complete yet (the estimate's lag).
    """

    processed: int = 0
    predicted: int = 0
    learnt: int = 0
    held_out: int = 0
    refused: int = 0
    no_effort: int = 0
    clipped: int = 0
    skipped: dict[SkipReason, int] = field(
        default_factory=lambda: dict.fromkeys(SkipReason, 0))
    pending: int = 0


class OnlineIdentifier:
    """Predict joint efforts from a joint-state stream and learn from it, sample by sample.

    Parameters
    ----------
    model : Estimator
        The model, learnt by ``trainer`` (a network's ``partial_fit`` by default);
        ``model.n_inputs`` must be ``3 * model.n_outputs``.
    joint_names : sequence of str, optional
        Joint order of the model's inputs and outputs; by default the first valid sample's.
    differentiator : AccelerationEstimate, optional
        The q'' estimate (owned from then on); by default the stage's zero-phase default.
    trainer : Trainer, optional
        How samples are learnt; by default per-sample :class:`BackPropagation`.
    holdout : Holdout, optional
        Validation blocks, never learnt.
    mse_window : int
        Latest predictions the error statistics cover, at least 100.
    learn : bool
        Learn from samples with a measured effort; False only predicts.
    max_gap_ns : int
        Clock jump (ns) that restarts the q'' estimate (see :class:`SampleCheck`).
    bounds : Bounds, optional
        Samples beyond them are refused as ``OUT_OF_LIMITS``; predictions beyond the effort
        bounds are clipped to them.
    stage : InputStage, optional
        A stage shared by several identifiers of one stream (the caller pushes each sample
        and hands the outcome to :meth:`take`); replaces ``joint_names``,
        ``differentiator``, ``max_gap_ns`` and the sample bounds.
    derive_velocity : bool
        The stage derives q' from q for a stream without velocities
        (:class:`~scara_ident_ros.identification.input_stage.InputStage`); with ``stage``
        unused.

    Raises
    ------
    ValueError
        If the model's sizes, ``joint_names`` or ``mse_window`` do not fit.
    learner : Polled, optional
        The trainer's learner process, if it learns beside the stream: polled every sample
        while ``learn`` (2.5 µs: a pipe's select), so that a finished update is taken even
        while a sample is not learnt (a held-out block, samples without effort). With
        ``learn`` False the model is frozen as it is: an update the learner finishes after
        the switch is taken only once learning resumes.
    """

    def __init__(self, model: Estimator, *, joint_names: Sequence[str] | None = None,
                 differentiator: AccelerationEstimate | None = None,
                 trainer: Trainer | None = None, holdout: Holdout | None = None,
                 mse_window: int = MSE_WINDOW, learn: bool = True,
                 max_gap_ns: int = DEFAULT_MAX_GAP_NS, bounds: Bounds | None = None,
                 stage: InputStage | None = None, derive_velocity: bool = False,
                 learner: Polled | None = None) -> None:
        n = model.n_outputs
        if n < 1 or model.n_inputs != 3 * n:
            raise ValueError(f'model has {model.n_inputs} inputs and {n} outputs; '
                             f'need 3n inputs [q, qd, qdd] for n >= 1 outputs')
        if mse_window < PAPER_WINDOW:
            raise ValueError(f'mse_window must be at least {PAPER_WINDOW}, got {mse_window}')
        self.model = model
        self.learn = learn
        if stage is None:
            stage = InputStage(JointMap(joint_names, n_joints=n), need_effort=False,
                               max_gap_ns=max_gap_ns, differentiator=differentiator,
                               bounds=bounds, derive_velocity=derive_velocity)
        self.stage = stage
        self.joint_map = stage.check.joint_map
        self.trainer: Trainer = trainer if trainer is not None else BackPropagation(model)
        self.learner = learner
        self.holdout = holdout
        self.errors = ErrorWindow(n, mse_window)
        self.counts = Counts(skipped=self.stage.skipped)
        self._effort_bounds = None if bounds is None else (bounds.lo[2], bounds.hi[2])

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.errors.n_joints

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joint order, or None until the first valid sample when not configured."""
        return self.joint_map.names

    @property
    def differentiator(self) -> AccelerationEstimate:
        """The q'' estimate."""
        return self.stage.differentiator

    @property
    def lag(self) -> int:
        """Samples by which a prediction follows its sample (the q'' estimate's lag)."""
        return self.stage.lag

    def process(self, stamp_ns: int, names: Sequence[str], position: FloatArrayLike,
                velocity: FloatArrayLike, effort: FloatArrayLike = ()) -> list[StepResult]:
        """Handle one joint-state sample: validate, then predict a priori, record, learn.

        Parameters
        ----------
        stamp_ns : int
            Time of the sample, integer nanoseconds (``header.stamp``).
        names : sequence of str of length m
            Joint names, in message order.
        position, velocity : array_like of shape (m,)
            q (rad or m) and q' (rad/s or m/s), in message order.
        effort : array_like of shape (m,) or (0,)
            Measured effort (N·m or N), in message order; empty if not measured.

        Returns
        -------
        list of StepResult
            A rejection of this sample (it changed only its counter), and/or the predictions
            of the samples whose input is now complete, oldest first, each with its own stamp.
        """
        reason, inputs = self.stage.push(stamp_ns, tuple(names), position, velocity, effort)
        return self.take(stamp_ns, reason, inputs)

    def take(self, stamp_ns: int, reason: SkipReason | None, inputs: Sequence[Input], *,
             pushed: bool = True) -> list[StepResult]:
        """Predict, record and learn what the stage gave for one sample (see ``stage``).

        Parameters
        ----------
        stamp_ns : int
            The sample's stamp (ns).
        reason, inputs
            What :meth:`InputStage.push` returned for it.
        pushed : bool
            The inputs come from a sample pushed now (counted as processed); False for
            those of :meth:`InputStage.flush` at the end of a stream.
        """
        if pushed:
            self.counts.processed += 1
        if self.learner is not None and self.learn:  # an update finished beside the stream,
            self.learner.poll()  # taken now, not only when a learnt sample sends a batch
        results = [StepResult(stamp_ns, None, reason)] if reason is not None else []
        results += [self._predict_and_learn(item) for item in inputs]
        self.counts.pending = self.stage.pending
        return results

    def finish(self) -> list[StepResult]:
        """End of the stream: predict (and learn) the samples still pending."""
        return self.take(0, None, self.stage.flush(), pushed=False)

    def _predict_and_learn(self, item: Input) -> StepResult:
        counts = self.counts
        index = counts.predicted
        counts.predicted += 1
        effort = item.effort
        if effort is None:
            counts.no_effort += 1
        held_out = (effort is not None and self.holdout is not None
                    and self.holdout.held_out(index, item.stamp_ns))
        if held_out:
            assert self.holdout is not None and effort is not None
            predicted = self.model.predict(item.x)
            self.holdout.add(item.x, effort)
            counts.held_out += 1
        elif effort is not None and self.learn:
            try:
                predicted = self.trainer.learn(item.x, effort)
                counts.learnt += 1
            except ValueError:
                predicted = self.model.predict(item.x)
                counts.refused += 1
        else:
            predicted = self.model.predict(item.x)
        if self._effort_bounds is not None:
            lo, hi = self._effort_bounds
            if not np.all((predicted >= lo) & (predicted <= hi)):
                np.clip(predicted, lo, hi, out=predicted)
                counts.clipped += 1
        if effort is not None:
            self.errors.update(effort, predicted)
        return StepResult(item.stamp_ns, predicted, None, held_out, effort)

    def error_stats(self) -> ErrorStats:
        """Return the error statistics over the last ``mse_window`` predictions."""
        return self.errors.snapshot()

    def paper_error(self) -> ErrorStats:
        """Return the paper's online figure: the statistics over the last 100 predictions."""
        return self.errors.recent(PAPER_WINDOW)

    def held_out_residuals(self) -> NDArray[np.float64] | None:
        """Measured − predicted effort of the current model on the held-out samples kept so
        far, shape (K, n) (N·m or N); None without a holdout or held-out samples."""
        if self.holdout is None or len(self.holdout.reservoir) == 0:
            return None
        reservoir = self.holdout.reservoir
        return np.asarray(reservoir.Y - self.model.predict(reservoir.X))

    def validation_stats(self) -> ErrorStats | None:
        """Score the current model on the held-out samples; None without any."""
        if self.holdout is None or len(self.holdout.reservoir) == 0:
            return None
        return self.holdout.score(self.model.predict(self.holdout.reservoir.X))

    def reset(self) -> None:
        """Forget the last stamp, the q'' history and the errors; keep the model, the joint
        order and the counters (pending samples count as skipped ``warming_up``)."""
        self.stage.reset()
        self.counts.pending = self.stage.pending
        self.errors.reset()
