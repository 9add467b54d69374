"""Online identification of the inverse dynamics, one joint-state sample at a time.

Per accepted sample: validate → differentiate q' into q'' → predict the effort from
x = [q, q', q''] → record the prediction error (if effort was measured) → learn from the
sample (one ``partial_fit`` step). The prediction is made *before* the model learns from the
sample, so it is an honest a-priori prediction and the recorded error is a true one-step
generalisation error, not a training error.

This module is pure numpy; the ROS node only converts ``sensor_msgs/JointState`` to the
arguments of :meth:`OnlineIdentifier.process`.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.differentiator import Differentiator
from scara_ident_ros.identification.error_window import PAPER_WINDOW, ErrorStats, ErrorWindow
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.sample_check import (DEFAULT_MAX_GAP_NS, FloatArrayLike,
                                                         SampleCheck)
from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['EffortModel', 'StepResult', 'Counts', 'OnlineIdentifier']


class EffortModel(Protocol):
    """What the identifier needs of a network: predict efforts from (q, q', q'') and learn.

    The input layout is ``x = [q_1..q_n, qd_1..qd_n, qdd_1..qdd_n]``, in physical units.
    """

    @property
    def n_inputs(self) -> int:
        """Number of inputs, 3n."""
        ...

    @property
    def n_outputs(self) -> int:
        """Number of outputs (joint efforts), n."""
        ...

    def predict(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return efforts of shape (N, n) for X of shape (N, 3n), or (n,) for (3n,).

        The result must be a new array (the identifier hands it out unchanged).
        """
        ...

    def partial_fit(self, X: NDArray[np.float64],
                    Y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Take one learning step per row of X (N, 3n) towards Y (N, n), in order.

        Returns the a-priori errors ``Y − predict(X)`` (N, n), each computed with the
        weights from before its own step, so that the identifier gets its a-priori
        prediction from the same forward pass as the learning step. Raises ValueError,
        leaving the weights unchanged, if a step would not be finite.
        """
        ...


@dataclass(frozen=True, slots=True)
class StepResult:
    """Outcome of one sample.

    Attributes
    ----------
    stamp_ns : int
        The sample's stamp, integer nanoseconds.
    effort : ndarray of shape (n_joints,) or None
        The a-priori predicted effort (N·m or N) in the configured joint order, or None if
        the sample was skipped.
    reason : SkipReason or None
        Why the sample was skipped, or None if a prediction was made.
    """

    stamp_ns: int
    effort: NDArray[np.float64] | None
    reason: SkipReason | None = None


@dataclass
class Counts:
    """Counters of an :class:`OnlineIdentifier`.

    ``processed == predicted + sum(skipped.values())`` always holds.

    Attributes
    ----------
    processed : int
        Samples passed to :meth:`OnlineIdentifier.process`.
    predicted : int
        Samples for which an effort was predicted.
    learned : int
        Samples the model learnt from.
    refused : int
        Samples predicted but not learnt from, because the model refused the step (it
        would not have been finite); the weights were left unchanged.
    skipped : dict of SkipReason to int
        Samples without a prediction, per reason (every reason present, from 0).
    """

    processed: int = 0
    predicted: int = 0
    learned: int = 0
    refused: int = 0
    skipped: dict[SkipReason, int] = field(
        default_factory=lambda: dict.fromkeys(SkipReason, 0))


class OnlineIdentifier:
    """Predict joint efforts from a joint-state stream and learn from it, sample by sample.

    Parameters
    ----------
    model : EffortModel
        The network; ``model.n_inputs`` must be ``3 * model.n_outputs``.
    joint_names : sequence of str, optional
        The joint order of the model's inputs and outputs; by default that of the first valid
        sample. Messages are always mapped to it by name.
    differentiator : Differentiator, optional
        Turns q' into q''; by default ``Differentiator('lowpass', cutoff_hz=50.0)``. It is
        owned by the identifier from then on.
    mse_window : int
        Number of latest predictions the error statistics cover, at least 100 (the paper's
        figure is over the last 100).
    learn : bool
        Learn from each sample. Without learning the model only predicts, and samples without
        effort are accepted (they are predicted but leave the error statistics unchanged).
    max_gap_ns : int
        A clock jump of more than this (ns) between accepted samples restarts the
        differentiator.

    Raises
    ------
    ValueError
        If the model's sizes, ``joint_names`` or ``mse_window`` do not fit.
    """

    def __init__(self, model: EffortModel, *, joint_names: Sequence[str] | None = None,
                 differentiator: Differentiator | None = None, mse_window: int = 1000,
                 learn: bool = True, max_gap_ns: int = DEFAULT_MAX_GAP_NS) -> None:
        n = model.n_outputs
        if n < 1 or model.n_inputs != 3 * n:
            raise ValueError(f'model has {model.n_inputs} inputs and {n} outputs; '
                             f'need 3n inputs [q, qd, qdd] for n >= 1 outputs')
        if mse_window < PAPER_WINDOW:
            raise ValueError(f'mse_window must be at least {PAPER_WINDOW}, got {mse_window}')
        self.model = model
        self.learn = learn
        self.joint_map = JointMap(joint_names, n_joints=n)
        self._check = SampleCheck(self.joint_map, need_effort=learn, max_gap_ns=max_gap_ns)
        self.differentiator = differentiator if differentiator is not None else Differentiator()
        self.errors = ErrorWindow(n, mse_window)
        self.counts = Counts()

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.errors.n_joints

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joint order, or None until the first valid sample when not configured."""
        return self.joint_map.names

    def process(self, stamp_ns: int, names: Sequence[str], position: FloatArrayLike,
                velocity: FloatArrayLike, effort: FloatArrayLike = ()) -> StepResult:
        """Handle one joint-state sample: validate, predict a priori, record, learn.

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
        StepResult
            The predicted effort in joint order, or why there is none. A rejected sample
            changes nothing but its counter: it reaches neither the differentiator nor the
            model.
        """
        counts = self.counts
        counts.processed += 1
        sample = self._check.check(stamp_ns, names, position, velocity, effort)
        if isinstance(sample, SkipReason):
            counts.skipped[sample] += 1
            return StepResult(stamp_ns, None, sample)
        if sample.gap:
            self.differentiator.reset()
        acceleration = self.differentiator.update(stamp_ns, sample.velocity)
        if acceleration is None:
            reason = SkipReason.GAP if sample.gap else SkipReason.WARMING_UP
            counts.skipped[reason] += 1
            return StepResult(stamp_ns, None, reason)
        x = np.concatenate((sample.position, sample.velocity, acceleration))
        effort = sample.effort
        if effort is not None and self.learn:
            # One forward pass serves both: the a-priori error of the learning step
            # gives the a-priori prediction.
            try:
                predicted = effort - self.model.partial_fit(x[np.newaxis],
                                                            effort[np.newaxis])[0]
                counts.learned += 1
            except ValueError:
                predicted = self.model.predict(x)
                counts.refused += 1
        else:
            predicted = self.model.predict(x)
        counts.predicted += 1
        if effort is not None:
            self.errors.update(effort, predicted)
        return StepResult(stamp_ns, predicted)

    def error_stats(self) -> ErrorStats:
        """Return the error statistics over the last ``mse_window`` predictions."""
        return self.errors.snapshot()

    def paper_error(self) -> ErrorStats:
        """Return the paper's online figure: the statistics over the last 100 predictions."""
        return self.errors.recent(PAPER_WINDOW)

    def reset(self) -> None:
        """Restart the stream: forget the last stamp, the derivative history and the errors.

        The model, the joint order and the counters are kept.
        """
        self._check.reset()
        self.differentiator.reset()
        self.errors.reset()
