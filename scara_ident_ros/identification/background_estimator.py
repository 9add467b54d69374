"""A kernel learner's ``partial_fit`` beside the stream, in a process of its own.

The message path only predicts, with the learner's latest state
(:class:`~scara_ident_ros.identification.streamed_estimator.StreamedEstimator`), and hands
each learnt sample to a learner process in small batches (one atomic pipe write each, never
waiting: :class:`BackgroundEstimator`). The process calls the learner's own ``partial_fit``
on the samples gathered (the first call once ``warmup`` have come, then whenever ``batch``
have: all those that came meanwhile, in order) and, at most every :data:`SNAPSHOT_PERIOD` s,
hands the learner's state back as its arrays (``to_arrays``), which the caller rebuilds
(``from_arrays``: the kernel's weights as they are, no solve) and predicts with from the next
sample on. Why a process: a kernel's hyperparameters cost 30-40 s once, the exact GP 5-10 ms
per learnt sample at 4000 points (:mod:`~scara_ident_ros.identification.estimator_learner`).

Messages are the small dataclasses below. Samples the pipe cannot take wait in a bounded
backlog, beyond which they are dropped and counted (:attr:`BackgroundEstimator.dropped`); a
learner slower than the stream takes more samples per call and hands back states less often
(:attr:`BackgroundEstimator.updates`, :meth:`BackgroundEstimator.rate`).
"""
from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.background_lm import (BACKLOG, BATCH_BYTES, NICE,
                                                          RATE_SPAN, STOP_TIMEOUT,
                                                          _set_title, _start_learner)
from scara_ident_ros.identification.estimator_learner import SampleBatch
from scara_ident_ros.identification.learner_stream import LearnerStream
from scara_ident_ros.identification.reservoir import RESERVOIR_SIZE
from scara_ident_ros.identification.streamed_estimator import (ArrayLearner,
                                                               StreamedEstimator, is_fitted)

__all__ = ['BackgroundEstimator', 'LearnerState', 'Ready', 'Samples', 'SNAPSHOT_PERIOD',
           'Start', 'Stop']

SNAPSHOT_PERIOD = 0.5  # s: the learner hands its state back at most this often
COMMAND = f'from {__name__} import main; main()'
_OVERHEAD = 400  # bytes of a Samples message besides its rows (pickle)


@dataclass(frozen=True)
class Start:
    """The learner to learn and how (the process's first message)."""

    learner: ArrayLearner
    batch: int
    warmup: int
    reservoir_size: int = RESERVOIR_SIZE  # the reservoir a fresh learner is refitted on
    seed: int = 0
    nice: int = NICE
    label: str = 'learner'


@dataclass(frozen=True)
class Samples:
    """Learnt samples, rows [x (3n), y (n)] of shape (N, 4n)."""

    rows: NDArray[np.float64]


@dataclass(frozen=True)
class Ready:
    """The learner has started (its first message)."""


@dataclass(frozen=True)
class Stop:
    """Learn what has come, hand the state back, end."""


@dataclass(frozen=True)
class LearnerState:
    """The learner's state after ``learnt`` samples in ``calls`` ``partial_fit`` calls
    (``seconds`` spent in them); ``arrays`` None while it has learnt nothing; ``last``:
    its final state (after :class:`Stop`)."""

    arrays: dict[str, np.ndarray] | None
    learnt: int
    calls: int
    seconds: float
    last: bool = False


class BackgroundEstimator:
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
                 reservoir_size: int = RESERVOIR_SIZE, seed: int = 0, label: str = 'learner'
                 ) -> None:
        self.model = model
        n = model.n_outputs
        self._batch = SampleBatch(n, max(1, (BATCH_BYTES - _OVERHEAD) // (8 * 4 * n)))
        self._backlog: deque[Samples | Stop] = deque()
        self.sent = self.dropped = self.updates = self.learnt = self.steps_taken = 0
        self.seconds = 0.0
        self._update_times: deque[float] = deque()
        self._batch_size, self._warmup = batch, warmup
        self._due: float | None = None
        self._closed = False
        self.ready = False  # the learner has started and waits for samples
        self._process, self._to_learner, self._from_learner = _start_learner(COMMAND)
        self._to_learner.send(Start(model.learner, batch, warmup, reservoir_size, seed,
                                    label=label))

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
        self.learnt, self.steps_taken = latest.learnt, latest.calls
        self.seconds = latest.seconds
        self._due = None
        if latest.arrays is None:
            return False
        self.model.replace(type(self.model.learner).from_arrays(
            latest.arrays, source=f'{self.model.kind} learner process'))
        self.updates += 1
        self._update_times.append(time.monotonic())
        return True

    def wait_ready(self, timeout: float) -> bool:
        """Wait (at most ``timeout`` s) until the learner has started; return whether it
        has (samples given before wait in the pipe either way)."""
        deadline = time.monotonic() + timeout
        while not self.ready and self.alive and time.monotonic() < deadline:
            if self._from_learner.poll(0.05):
                self.poll()
        return self.ready

    def rate(self) -> float:
        """States taken per second over the last :data:`RATE_SPAN` s."""
        times, now = self._update_times, time.monotonic()
        while times and times[0] < now - RATE_SPAN:
            times.popleft()
        return len(times) / RATE_SPAN

    def overdue(self) -> float | None:
        """Seconds since a ``partial_fit`` call fell due without a state coming back, or
        None."""
        return None if self._due is None else time.monotonic() - self._due

    @property
    def alive(self) -> bool:
        """Whether the learner process runs."""
        return self._process.poll() is None

    def _send(self, item: Samples | Stop | None) -> None:
        backlog = self._backlog
        if item is not None:
            backlog.append(item)
        while backlog and select.select([], [self._to_learner], [], 0)[1]:
            try:
                self._to_learner.send(backlog[0])
            except (BrokenPipeError, OSError):  # the learner has ended
                backlog.clear()
                return
            backlog.popleft()
        while len(backlog) > BACKLOG:
            dropped = backlog.popleft()
            if isinstance(dropped, Samples):
                self.dropped += dropped.rows.shape[0]

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
        if self._process.poll() is None:
            self._process.terminate()
        try:
            self._process.wait(1.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._to_learner.close()
        self._from_learner.close()

    def _take(self, state: LearnerState) -> None:
        self.learnt, self.steps_taken, self.seconds = state.learnt, state.calls, state.seconds
        if state.arrays is not None:
            self.model.replace(type(self.model.learner).from_arrays(
                state.arrays, source=f'{self.model.kind} learner process'))
            self.updates += 1


def _learn(inbox: Connection, outbox: Connection, start: Start) -> None:
    """The learner process: gather samples, ``partial_fit`` them, hand states back."""
    from scara_ident_ros.blas_threads import single_blas_thread

    try:
        os.nice(start.nice)
    except OSError:
        pass
    _set_title(f'scara_ident_ros learner {start.label}')
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the caller stops it (close)
    stream = LearnerStream(start.learner, reservoir_size=start.reservoir_size,
                           warmup=start.warmup, seed=start.seed)
    lock = threading.Condition()
    pending: list[NDArray[np.float64]] = []
    state = {'new': 0, 'stop': False}

    def read() -> None:
        try:
            while True:
                message = inbox.recv()
                with lock:
                    if isinstance(message, Samples):
                        pending.append(message.rows)
                        state['new'] += message.rows.shape[0]
                    elif isinstance(message, Stop):
                        state['stop'] = True
                    lock.notify()
                if state['stop']:
                    return
        except (EOFError, OSError):  # the caller has gone
            with lock:
                state['stop'] = True
                lock.notify()

    threading.Thread(target=read, name='learner-inbox', daemon=True).start()
    try:
        outbox.send(Ready())
    except (BrokenPipeError, OSError):  # the caller has gone already
        return
    learnt = calls = 0
    seconds, sent_at = 0.0, -np.inf
    fitted, unsent = is_fitted(stream.learner), False
    with single_blas_thread():
        while True:
            with lock:
                while not state['stop'] and state['new'] < (
                        start.batch if fitted else start.warmup) and not (
                        unsent and time.monotonic() - sent_at >= SNAPSHOT_PERIOD):
                    lock.wait(SNAPSHOT_PERIOD)
                last = bool(state['stop'])
                rows = np.concatenate(pending) if pending else None
                pending.clear()
                state['new'] = 0
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
    """The learner process (:data:`COMMAND` READ_FD WRITE_FD): waits for its :class:`Start`."""
    args = sys.argv[1:] if argv is None else argv
    inbox = Connection(int(args[0]), writable=False)
    outbox = Connection(int(args[1]), readable=False)
    try:
        start = inbox.recv()
    except (EOFError, OSError):
        return
    _learn(inbox, outbox, start)
