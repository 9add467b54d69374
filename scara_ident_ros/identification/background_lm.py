"""Levenberg–Marquardt beside the stream: the reservoir and its steps in a process of its own.

The message path of an identifier must cost microseconds per sample whatever the trainer
does; an LM step on a reservoir of thousands of samples costs tens of milliseconds. So
:class:`BackgroundLM` keeps only the prediction in the caller's process: each sample is
predicted with the weights of the moment (a priori, before it is learnt) and put in a small
batch; full batches go down a pipe to a learner process
(:mod:`~scara_ident_ros.identification.lm_process`), which keeps the
:class:`~scara_ident_ros.identification.reservoir_lm.ReservoirLM` (reservoir, slow reservoir, LM
state), takes ``steps`` LM steps whenever at least ``interval`` new samples have come, and
sends the new weights back. The caller takes them between two samples
(:meth:`BackgroundLM.poll`, called with every batch sent and by the identifier every
sample), so a prediction never sees half an update.

The learner runs at a lower CPU priority (``nice``) with one BLAS thread: when the CPU is
short, the stream's processes (simulator, message paths, recorder) go first and learning
slows down; :attr:`BackgroundLM.updates` and :meth:`BackgroundLM.rate` say by how much, and
:meth:`BackgroundLM.overdue` how long an update has been due (a busy CPU can starve it).
A process rather than a thread: the steps' Python glue would otherwise hold the GIL that
the message path needs, and a thread's priority cannot be lowered without risking that the
GIL waits for it.

A hybrid's network (``hybrid``: :class:`~scara_ident_ros.learners.hybrid_model.HybridModel`)
learns there as in the caller's process
(:class:`~scara_ident_ros.identification.residual_learner.ResidualLearner`): its residuals of
the current θ, each update checked on held-back samples, the correction bounded. The
message path sends (x, τ) as for a network, and with each batch the physical model's θ of
the moment (p floats); the learner rebuilds the physical model from its URDF and computes
the regressor rows Y(x) only for the samples its reservoirs keep. It hands back the weights
with the bounds and the per-joint gate (and those alone after an update that was undone).

The message path never blocks on the pipe (:class:`~scara_ident_ros.identification.
learner_process.LearnerClient`: a bounded backlog, samples beyond it dropped and counted in
:attr:`BackgroundLM.dropped`); the messages are typed
(:mod:`~scara_ident_ros.identification.learner_messages`).
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.learner_messages import (LmStart, LmUpdate, Samples,
                                                             Schedule, Stop)
from scara_ident_ros.identification.learner_process import (BACKLOG, BATCH_BYTES,
                                                            STOP_TIMEOUT, LearnerClient)
from scara_ident_ros.identification.learner_process import prestart as _prestart
from scara_ident_ros.identification.learner_settings import LearnerSettings
from scara_ident_ros.learners.data_region import DataRegion
from scara_ident_ros.identification.lm_process import COMMAND
from scara_ident_ros.nn import FeedForwardNet

if TYPE_CHECKING:
    from scara_ident_ros.learners.hybrid_model import HybridModel

__all__ = ['BACKLOG', 'BackgroundLM', 'prestart']


def prestart(count: int) -> None:
    """Start ``count`` ``lm`` learner processes now, before the stream: the next
    :class:`BackgroundLM` objects take them instead of starting their own, so that the
    interpreters' start (about 0.6 s of CPU each) does not compete with the first samples.
    """
    _prestart(COMMAND, count)


class BackgroundLM(LearnerClient):
    """The ``lm`` trainer with its reservoir and steps in a learner process.

    Parameters
    ----------
    model : FeedForwardNet
        The network the caller predicts with (its scaling set); the learner starts from a
        copy of its weights, and every update it sends is copied into it.
    settings : LearnerSettings
        The reservoir and the steps. ``lm_interval`` is the least number of new samples
        between two updates: with the CPU to spare, an update starts as soon as that many
        have come; without, later.
    hybrid : HybridModel, optional
        The hybrid ``model`` is the network of: the learner fits ``model`` to the residuals
        of its physical part's latest θ (module docstring) and the bounds it sends are set
        on it. Samples are then handed over with :meth:`add` (the caller predicts).

    Attributes
    ----------
    sent : int
        Samples handed to the learner (the ``learnt`` samples of an identifier).
    dropped : int
        Samples not learnt because the learner could not take them (backlog full).
    updates : int
        Updates (``lm_steps`` LM steps each) whose weights the model has taken.
    steps_taken : int
        LM steps the learner has taken, as of its latest update.
    undone : int
        A hybrid's updates undone by the learner's validation check.

    An update is due (:meth:`overdue`) once ``lm_interval`` samples are sent after the
    learner's last finished update (or its start); a hybrid's update its check undoes counts
    as finished.
    """

    name = 'lm'

    def __init__(self, model: FeedForwardNet, settings: LearnerSettings = LearnerSettings(),
                 *, hybrid: HybridModel | None = None) -> None:
        if hybrid is not None and hybrid.network is not model:
            raise ValueError('hybrid must be the model whose network the learner learns')
        self.model = model
        self.settings = settings
        self.hybrid = hybrid
        width = model.n_inputs + model.n_outputs
        theta_bytes = 8 * hybrid.physical.n_parameters if hybrid is not None else 0
        self._batch = np.empty((max(1, (BATCH_BYTES - theta_bytes) // (8 * width)), width))
        self._n = 0
        self.steps_taken = 0
        self.undone = 0
        # an update is due once `lm_interval` samples are sent after the learner's last
        # finished one (or its start): _mark is `sent` then
        self._interval = settings.lm_interval
        self._mark = 0
        physical = hybrid.physical.to_arrays() if hybrid is not None else None
        super().__init__(COMMAND, LmStart(model, settings, physical))

    # ------------------------------------------------------------------ message path
    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Predict ``y`` (n,) from ``x`` (3n,) with the current weights, then hand the sample
        to the learner; never waits for it."""
        predicted = self.model.predict(x)
        self.add(x, y)
        return predicted

    def add(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Hand the sample x (3n,), y (n,) to the learner, without predicting; never waits
        for it. A hybrid's batch goes with its physical part's θ as it is then."""
        row = self._batch[self._n]
        n_in = x.shape[0]
        row[:n_in] = x
        row[n_in:] = y
        self._n += 1
        self.sent += 1
        if self._due is None and self.sent - self._mark >= self._interval:
            self._due = time.monotonic()
        if self._n == self._batch.shape[0]:
            self._send(self._message(self._batch.copy()))
            self._n = 0
            self.poll()

    def _message(self, batch: NDArray[np.float64]) -> Samples:
        """A batch as sent, with a hybrid's θ of the moment."""
        if self.hybrid is None:
            return Samples(batch)
        return Samples(batch, np.array(self.hybrid.physical.theta, dtype=np.float64))

    def poll(self) -> bool:
        """Take the newest weights the learner has sent, if any; return whether it had."""
        got = False
        try:
            while self._from_learner.poll():
                answer = self._from_learner.recv()
                self.ready = True
                if not isinstance(answer, LmUpdate):
                    continue  # Ready or Stopped: no model to take
                self._mark, self._due = self.sent, None  # an update has finished
                if answer.theta is not None:
                    self.model.set_theta(answer.theta)
                    self.steps_taken = answer.steps
                    self._took_update()
                    got = True
                if answer.hybrid is not None and self.hybrid is not None:
                    self.hybrid.bounds = answer.hybrid.bounds
                    self.undone, self.hybrid.gate = answer.hybrid.undone, answer.hybrid.gate
                    if answer.hybrid.region is not None:
                        self.hybrid.region = DataRegion.from_arrays(answer.hybrid.region)
        except (EOFError, OSError):  # the learner has ended: keep the weights we have
            pass
        return got

    def set_schedule(self, *, lm_interval: int, lm_steps: int) -> None:
        """Change the least samples between updates and the steps per update, from now on."""
        self._interval = int(lm_interval)
        self._send(Schedule(int(lm_interval), int(lm_steps)))

    # ------------------------------------------------------------------ stop
    def close(self, timeout: float = STOP_TIMEOUT) -> None:
        """Hand over the last samples, let the learner finish its step, take its last
        weights and end it (at most ``timeout`` s, then it is terminated)."""
        if self._closed:
            return
        self._closed = True
        if self._n:
            self._send(self._message(self._batch[:self._n].copy()))
            self._n = 0
        deadline = time.monotonic() + timeout
        while self._backlog and time.monotonic() < deadline and self.alive:
            self._send(None)
            time.sleep(0.001)
        self._backlog.clear()
        try:
            self._to_learner.send(Stop())
        except (BrokenPipeError, OSError):
            pass
        while time.monotonic() < deadline and self.alive:
            self.poll()
            time.sleep(0.005)
        self.poll()
        self._end()
