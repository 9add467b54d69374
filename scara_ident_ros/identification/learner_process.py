"""A learner in a process of its own: starting it, the caller's end of its pipes, its end.

Both background learners (:class:`~scara_ident_ros.identification.background_lm.BackgroundLM`
for the ``lm`` trainer, :class:`~scara_ident_ros.identification.background_estimator.
BackgroundEstimator` for the learners' ``partial_fit``) keep the prediction in the caller's
process and the learning in a learner process; what they share is here:

- :func:`start_learner`: a fresh interpreter (not fork: the caller has DDS threads; not
  multiprocessing's spawn: it re-runs the caller's ``__main__``) with one BLAS thread, two
  pipes, the program given as ``python -c``, in a process group of its own: a terminal's
  Ctrl-C (SIGINT to the foreground group) reaches the caller alone, which stops its
  learners; a learner also ends when its pipe from the caller closes (the caller gone).
  :func:`prestart` starts some ahead of the stream; those not taken are ended and reaped
  when the caller exits;
- :class:`LearnerClient`: the caller's end. It never blocks on the pipe: a message is written
  only when the pipe has room for it in one atomic write (``select``); otherwise it waits in
  a bounded backlog (:data:`BACKLOG`), beyond which samples are dropped and counted. It keeps
  readiness, the update rate and how long an update has been due, and ends the process;
- :func:`run_learner`, :func:`enter_learner` and :class:`Inbox`: the learner's end (its
  pipes from its arguments and its start message; its niceness, process title and signals;
  its inbox read in a thread of its own, so that the pipe is drained even while it learns).

The messages are those of :mod:`~scara_ident_ros.identification.learner_messages`.
"""
from __future__ import annotations

import atexit
import os
import select
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from scara_ident_ros.identification.learner_messages import Ready, Samples, Stop

__all__ = ['BACKLOG', 'BATCH_BYTES', 'Inbox', 'LearnerClient', 'RATE_SPAN',
           'STOP_TIMEOUT', 'end_prestarted', 'enter_learner', 'prestart', 'run_learner',
           'start_learner']

#: Bytes of one batch message at most: below PIPE_BUF (4096 on Linux), so a write into a
#: pipe that select() calls writable neither blocks nor interleaves.
BATCH_BYTES = 3000
BACKLOG = 2000  # messages kept while the pipe is full (at 1 kHz, 4 joints: ~30 s of samples)
STOP_TIMEOUT = 10.0  # s the learner gets to finish its work and send its last state
RATE_SPAN = 10.0  # s over which updates per second are reported

Learner = tuple[subprocess.Popen[bytes], Connection, Connection]
_PRESTARTED: dict[str, list[Learner]] = {}  # by program: started ahead, waiting for a start


def start_learner(command: str) -> Learner:
    """Start a learner process running ``command`` (a ``python -c`` program given the two
    pipes' descriptors as arguments); return it with the pipes to and from it."""
    learner_reads, we_write = os.pipe()
    we_read, learner_writes = os.pipe()
    env = dict(os.environ, OPENBLAS_NUM_THREADS='1', OMP_NUM_THREADS='1',
               MKL_NUM_THREADS='1')
    process = subprocess.Popen(
        [sys.executable, '-c', command, str(learner_reads), str(learner_writes)],
        pass_fds=(learner_reads, learner_writes), env=env, stdin=subprocess.DEVNULL,
        process_group=0)
    os.close(learner_reads)
    os.close(learner_writes)
    return process, Connection(we_write, readable=False), Connection(we_read, writable=False)


def prestart(command: str, count: int) -> None:
    """Start ``count`` learner processes of ``command`` now, before the stream: the next
    clients of that program take them instead of starting their own, so that the
    interpreters' start (about 0.6 s of CPU each) does not compete with the first samples."""
    if not _PRESTARTED:
        atexit.register(end_prestarted)
    waiting = _PRESTARTED.setdefault(command, [])
    while len(waiting) < count:
        waiting.append(start_learner(command))


def end_prestarted() -> None:
    """End the learner processes :func:`prestart` started that no client took, and reap
    them (they wait for a start message, or are still starting: SIGTERM ends either at
    once). Called at the caller's exit, so that none outlives it."""
    for waiting in _PRESTARTED.values():
        while waiting:
            process, to_learner, from_learner = waiting.pop()
            if process.poll() is None:
                process.terminate()
            process.wait()
            to_learner.close()
            from_learner.close()


def run_learner(learn: Callable[[Connection, Connection, Any], None],
                argv: list[str] | None = None) -> None:
    """The learner's end: its inbox and outbox from the descriptors of its arguments
    (``READ_FD WRITE_FD``); wait for the start message, then ``learn(inbox, outbox, start)``.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the caller stops it (enter_learner)
    args = sys.argv[1:] if argv is None else argv
    inbox = Connection(int(args[0]), writable=False)
    outbox = Connection(int(args[1]), readable=False)
    try:
        start = inbox.recv()
    except (EOFError, OSError):  # the caller has gone before starting it
        return
    learn(inbox, outbox, start)


def enter_learner(nice: int, label: str) -> None:
    """Make this process a learner: ``nice`` lower priority, named ``scara_ident_ros learner
    LABEL`` in ``ps``/``top`` (Linux: its comm, 15 characters), Ctrl-C ignored (the caller
    stops it)."""
    try:
        os.nice(nice)
    except OSError:
        pass
    try:
        Path('/proc/self/comm').write_text(f'scara_ident_ros learner {label}'[-15:])
    except OSError:
        pass
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class Inbox:
    """A learner's inbox, read in a thread of its own (:meth:`start`).

    Each message but :class:`Stop` is handed to ``take`` under :attr:`lock`, which returns
    the samples it added; :attr:`new` counts them until the learner resets it. :class:`Stop`,
    or the caller gone, sets :attr:`stopped`. Each message notifies :attr:`lock`, a
    condition the learner waits on.
    """

    def __init__(self, connection: Connection, take: Callable[[Any], int]) -> None:
        self.lock = threading.Condition()
        self.new = 0
        self.stopped = False
        self._connection, self._take = connection, take

    def start(self, outbox: Connection, name: str) -> bool:
        """Start reading, then answer :class:`Ready` on ``outbox``; return False if the
        caller has gone already."""
        threading.Thread(target=self._read, name=name, daemon=True).start()
        try:
            outbox.send(Ready())
        except (BrokenPipeError, OSError):
            return False
        return True

    def _read(self) -> None:
        try:
            while not self.stopped:
                message = self._connection.recv()
                with self.lock:
                    if isinstance(message, Stop):
                        self.stopped = True
                    else:
                        self.new += self._take(message)
                    self.lock.notify()
        except (EOFError, OSError):  # the caller has gone
            with self.lock:
                self.stopped = True
                self.lock.notify()


class LearnerClient:
    """The caller's end of a learner process (module docstring).

    Parameters
    ----------
    command : str
        The learner's program (:func:`start_learner`); a process :func:`prestart` started
        for it is taken if one waits.
    start : object
        The first message, which the learner waits for.

    Attributes
    ----------
    sent : int
        Samples handed over.
    dropped : int
        Samples not learnt: the pipe and the backlog were full.
    updates : int
        Updates taken from the learner.
    steps_taken : int
        The learner's steps (LM steps; ``partial_fit`` calls), as of its latest update.
    ready : bool
        Whether the learner has answered (started).
    """

    def __init__(self, command: str, start: Any) -> None:
        waiting = _PRESTARTED.get(command)
        self._process, self._to_learner, self._from_learner = (
            waiting.pop() if waiting else start_learner(command))
        self._backlog: deque[Any] = deque()
        self._update_times: deque[float] = deque()
        self._due: float | None = None  # when an update fell due, if one is due
        self._closed = False
        self.sent = self.dropped = self.updates = self.steps_taken = 0
        self.ready = False
        self._to_learner.send(start)  # the learner waits for it

    def poll(self) -> bool:  # pragma: no cover - each client's own
        """Take what the learner has answered; return whether the model changed."""
        raise NotImplementedError

    def close(self, timeout: float = STOP_TIMEOUT) -> None:  # pragma: no cover - its own
        """Hand over the last samples, take the learner's last update and end it (at most
        ``timeout`` s)."""
        raise NotImplementedError

    def wait_ready(self, timeout: float) -> bool:
        """Wait (at most ``timeout`` s) until the learner has started; return whether it
        has (samples given before are not lost either way: they wait in the pipe)."""
        deadline = time.monotonic() + timeout
        while not self.ready and self.alive and time.monotonic() < deadline:
            if self._from_learner.poll(0.05):
                self.poll()
        return self.ready

    def rate(self) -> float:
        """Updates taken per second over the last :data:`RATE_SPAN` s."""
        times, now = self._update_times, time.monotonic()
        while times and times[0] < now - RATE_SPAN:
            times.popleft()
        return len(times) / RATE_SPAN

    def overdue(self) -> float | None:
        """Seconds since an update fell due without one finishing; None if none is due."""
        return None if self._due is None else time.monotonic() - self._due

    @property
    def alive(self) -> bool:
        """Whether the learner process runs."""
        return self._process.poll() is None

    def _took_update(self) -> None:
        """Count an update taken now (:meth:`rate`)."""
        self.updates += 1
        self._update_times.append(time.monotonic())

    def _send(self, message: Any) -> None:
        """Queue ``message`` (None: nothing new) and write what the pipe takes without
        blocking; beyond :data:`BACKLOG` queued, the oldest go and their samples count as
        dropped."""
        backlog = self._backlog
        if message is not None:
            backlog.append(message)
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

    def _end(self) -> None:
        """Terminate the process if it still runs (after 1 s, kill it) and close the pipes."""
        if self._process.poll() is None:
            self._process.terminate()
        try:
            self._process.wait(1.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._to_learner.close()
        self._from_learner.close()
