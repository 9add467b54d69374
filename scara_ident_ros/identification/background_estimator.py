"""A kernel learner's ``partial_fit`` beside the stream, in a process of its own.

The message path only predicts, with the learner's latest state
(:class:`~scara_ident_ros.identification.streamed_estimator.StreamedEstimator`), and hands
each learnt sample to a learner process in small batches (one atomic pipe write each, never
waiting: :class:`BackgroundEstimator`). The process
(:mod:`~scara_ident_ros.identification.estimator_process`) calls the learner's own
``partial_fit`` on the samples gathered (the first call once ``warmup`` have come, then
whenever ``batch`` have) and, every half second at most, hands the learner's state back as
its arrays (``to_arrays``), which the caller rebuilds
(``from_arrays``: the kernel's weights as they are, no solve) and predicts with from the next
sample on. Why a process: a kernel's hyperparameters cost 30-40 s once, the exact GP 5-10 ms
per learnt sample at 4000 points (:mod:`~scara_ident_ros.identification.estimator_learner`).

Messages are typed (:mod:`~scara_ident_ros.identification.learner_messages`). Samples the
pipe cannot take wait in a bounded backlog, beyond which they are dropped and counted
(:attr:`BackgroundEstimator.dropped`); a learner slower than the stream takes more samples
per call and hands back states less often (:attr:`BackgroundEstimator.updates`,
:meth:`BackgroundEstimator.rate`).
"""
from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.estimator_learner import SampleBatch
from scara_ident_ros.identification.estimator_process import COMMAND
from scara_ident_ros.identification.learner_messages import (EstimatorStart, LearnerState,
                                                             Samples, Stop)
from scara_ident_ros.identification.learner_process import (BATCH_BYTES, STOP_TIMEOUT,
                                                            LearnerClient)
from scara_ident_ros.identification.learner_settings import NICE
from scara_ident_ros.identification.reservoir_lm import RESERVOIR_SIZE
from scara_ident_ros.identification.streamed_estimator import StreamedEstimator

__all__ = ['BackgroundEstimator']

_OVERHEAD = 400  # bytes of a Samples message besides its rows (pickle)


class BackgroundEstimator(LearnerClient):
    """Predict in the caller's process, learn in a learner process (module docstring).

    Parameters
    ----------
    model : StreamedEstimator
        The identifier's model; its learner is replaced by each state handed back.
    batch, warmup : int
        Samples per ``partial_fit`` call (at least), of the first call.
    reservoir_size, seed : int
        The reservoir a fresh learner is refitted on, and its seed
        (:class:`~scara_ident_ros.identification.learner_stream.LearnerStream`).
    label : str
        Names the process (``ps``, ``top``).

    Attributes
    ----------
    sent : int
        Samples handed over (the identifier's learnt samples).
    dropped : int
        Samples not learnt: the pipe and the backlog were full.
    updates : int
        States taken from the learner.
    learnt, steps_taken : int
        Samples the learner had learnt, and its ``partial_fit`` calls, as of the latest
        state taken.
    seconds : float
        Time the learner had spent learning (s), as of the latest state.
    """

    name = 'estimator'

    def __init__(self, model: StreamedEstimator, *, batch: int, warmup: int,
                 reservoir_size: int = RESERVOIR_SIZE, seed: int = 0,
                 label: str = 'learner') -> None:
        self.model = model
        n = model.n_outputs
        self._batch = SampleBatch(n, max(1, (BATCH_BYTES - _OVERHEAD) // (8 * 4 * n)))
        self.learnt = self.steps_taken = 0
        self.seconds = 0.0
        self._batch_size, self._warmup = batch, warmup
        super().__init__(COMMAND, EstimatorStart(model.learner, batch, warmup, reservoir_size,
                                                 seed, NICE, label))

    # ------------------------------------------------------------------ message path
    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Predict ``y`` (n,) from ``x`` (3n,) with the latest state, then hand the sample
        over; never waits for the learner."""
        self.poll()
        model = self.model
        predicted = model.predict(x)
        if not model.fitted:
            model.observe(y)
        self._batch.add(x, y)
        self.sent += 1
        due = self._batch_size if model.fitted else self._warmup
        if self._due is None and self.sent - self.learnt >= due:
            self._due = time.monotonic()
        if self._batch.size == self._batch._rows.shape[0]:
            self._flush_batch()
        return predicted

    def _flush_batch(self) -> None:
        if self._batch.size:
            X, Y = self._batch.take()
            self._send(Samples(np.hstack([X, Y])))

    def poll(self) -> bool:
        """Take the learner's newest state, if it has handed one back; return whether."""
        latest: LearnerState | None = None
        try:
            while self._from_learner.poll():
                message = self._from_learner.recv()
                self.ready = True
                if isinstance(message, LearnerState):
                    latest = message
        except (EOFError, OSError):  # the learner has ended: keep the state we have
            pass
        if latest is None:
            return False
        self._due = None
        return self._take(latest)

    # ------------------------------------------------------------------ stop
    def close(self, timeout: float = STOP_TIMEOUT) -> None:
        """Hand over the last samples, take the learner's final state (at most
        ``timeout`` s, then the process is terminated) and end it."""
        if self._closed:
            return
        self._closed = True
        self._flush_batch()
        self._send(Stop())
        deadline = time.monotonic() + timeout
        final = False
        while time.monotonic() < deadline and self.alive and not final:
            self._send(None)
            try:
                if self._from_learner.poll(0.01):
                    message = self._from_learner.recv()
                    if isinstance(message, LearnerState):
                        final = message.last
                        self._take(message)
            except (EOFError, OSError):
                break
        self._end()

    def _take(self, state: LearnerState) -> bool:
        """Take ``state``'s counts, and its learner if it has one; return whether."""
        self.learnt, self.steps_taken, self.seconds = state.learnt, state.calls, state.seconds
        if state.arrays is None:
            return False
        self.model.replace(type(self.model.learner).from_arrays(
            state.arrays, source=f'{self.model.kind} learner process'))
        self._took_update()
        return True


