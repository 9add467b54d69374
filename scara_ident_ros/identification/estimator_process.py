"""The learners' learner process: their own ``partial_fit`` on the samples gathered.

Started by :class:`~scara_ident_ros.identification.background_estimator.BackgroundEstimator`
(the caller's end; why a process: its module docstring) as ``python -c COMMAND READ_FD
WRITE_FD``. It waits for its :class:`~scara_ident_ros.identification.learner_messages.
EstimatorStart`, calls the learner's ``partial_fit`` on the samples gathered (the first call
once ``warmup`` have come, then whenever ``batch`` have: all those that came meanwhile, in
order, through a :class:`~scara_ident_ros.identification.learner_stream.LearnerStream`) and,
at most every :data:`SNAPSHOT_PERIOD` s, hands the learner's state back as its arrays
(:class:`~scara_ident_ros.identification.learner_messages.LearnerState`); on
:class:`~scara_ident_ros.identification.learner_messages.Stop`, its final state.
"""
from __future__ import annotations

import time
from multiprocessing.connection import Connection

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.learner_messages import (EstimatorStart, LearnerState,
                                                             Samples)
from scara_ident_ros.identification.learner_process import Inbox, enter_learner, run_learner
from scara_ident_ros.identification.learner_stream import LearnerStream
from scara_ident_ros.identification.streamed_estimator import is_fitted

__all__ = ['COMMAND', 'SNAPSHOT_PERIOD', 'main']

SNAPSHOT_PERIOD = 0.5  # s: the learner hands its state back at most this often
COMMAND = f'from {__name__} import main; main()'


def _learn(inbox_connection: Connection, outbox: Connection,
           start: EstimatorStart) -> None:
    """The learner process: gather samples, ``partial_fit`` them, hand states back."""
    from scara_ident_ros.blas_threads import single_blas_thread

    enter_learner(start.nice, start.label)
    stream = LearnerStream(start.learner, reservoir_size=start.reservoir_size,
                           warmup=start.warmup, seed=start.seed)
    pending: list[NDArray[np.float64]] = []

    def take(message: object) -> int:  # under the inbox's lock
        if isinstance(message, Samples):
            pending.append(message.rows)
            return int(message.rows.shape[0])
        return 0

    inbox = Inbox(inbox_connection, take)
    if not inbox.start(outbox, 'learner-inbox'):
        return
    learnt = calls = 0
    seconds, sent_at = 0.0, -np.inf
    fitted, unsent = is_fitted(stream.learner), False
    with single_blas_thread():
        while True:
            with inbox.lock:
                while not inbox.stopped and inbox.new < (
                        start.batch if fitted else start.warmup) and not (
                        unsent and time.monotonic() - sent_at >= SNAPSHOT_PERIOD):
                    inbox.lock.wait(SNAPSHOT_PERIOD)
                last = bool(inbox.stopped)
                rows = np.concatenate(pending) if pending else None
                pending.clear()
                inbox.new = 0
            if rows is not None:
                n_in = rows.shape[1] * 3 // 4
                began = time.perf_counter()
                stream.learn(rows[:, :n_in], rows[:, n_in:])
                seconds += time.perf_counter() - began
                learnt += rows.shape[0]
                calls += 1
                fitted, unsent = fitted or is_fitted(stream.learner), True
            if last or (unsent and time.monotonic() - sent_at >= SNAPSHOT_PERIOD):
                arrays = stream.learner.to_arrays() if fitted else None
                try:
                    outbox.send(LearnerState(arrays, learnt, calls, seconds, last))
                except (BrokenPipeError, OSError):
                    return
                sent_at, unsent = time.monotonic(), False
            if last:
                return


def main(argv: list[str] | None = None) -> None:
    """The learner process (:data:`COMMAND` READ_FD WRITE_FD): waits for its
    :class:`~scara_ident_ros.identification.learner_messages.EstimatorStart`."""
    run_learner(_learn, argv)
