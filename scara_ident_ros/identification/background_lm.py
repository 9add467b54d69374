"""Levenberg–Marquardt beside the stream: the reservoir and its steps in a process of its own.

The message path of an identifier must cost microseconds per sample whatever the trainer
does; an LM step on a reservoir of thousands of samples costs tens of milliseconds. So
:class:`BackgroundLM` keeps only the prediction in the caller's process: each sample is
predicted with the weights of the moment (a priori, before it is learnt) and put in a small
batch; full batches go down a pipe to a learner process (:func:`_learner`), which keeps the
:class:`~scara_ident_ros.identification.reservoir_lm.ReservoirLM` (reservoir, slow reservoir, LM
state), takes ``steps`` LM steps whenever at least ``interval`` new samples have come, and
sends the new weights back. The caller takes them between two samples
(:meth:`BackgroundLM.poll`), so a prediction never sees half an update.

An update takes the reservoir as it is when it starts; the samples that come during it
count towards the next. Without new samples (the robot at rest, the stream ended) there
is no update, so an idle stream costs no CPU; on stop, one last update takes the samples
that came since the previous one.

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

The message path never blocks on the pipe: a batch is written only when the pipe has room
for it in one atomic write (``select``); otherwise it waits in a bounded backlog, and
batches beyond that are dropped and counted (:attr:`BackgroundLM.dropped`). The learner
reads the pipe in a thread of its own, so it drains it even during a step.
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
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.reservoir_lm import (LM_INTERVAL, LM_STEPS, RESERVOIR_SIZE,
                                                         ReservoirLM)
from scara_ident_ros.nn import FeedForwardNet

if TYPE_CHECKING:
    from scara_ident_ros.learners.hybrid_model import HybridModel

__all__ = ['NICE', 'BackgroundLM', 'LearnerSettings', 'prestart']

#: Bytes of one batch message at most: below PIPE_BUF (4096 on Linux), so a write into a
#: pipe that select() calls writable neither blocks nor interleaves.
BATCH_BYTES = 3000
BACKLOG = 2000  # batches kept while the pipe is full (at 1 kHz, 4 joints: ~30 s of samples)
STOP_TIMEOUT = 10.0  # s the learner gets to finish its step and send its last weights
NICE = 10  # the learner's niceness: below the stream's processes (0), above `nice 19` jobs
RATE_SPAN = 10.0  # s over which updates per second are reported
#: The learner process's program: run with ``-c`` rather than ``-m``, which would import
#: this module twice (once as the package's, once as ``__main__``).
LEARNER_COMMAND = f'from {__name__} import main; main()'


@dataclass(frozen=True)
class LearnerSettings:
    """What the learner process builds its :class:`ReservoirLM` from (see there)."""

    reservoir_size: int = RESERVOIR_SIZE
    lm_interval: int = LM_INTERVAL
    lm_steps: int = LM_STEPS
    seed: int = 0
    lm_float64: bool = False
    lm_slow_share: float = 0.0
    lm_nice: int = NICE
    label: str = 'lm'  # names the learner (e.g. the method): its process title, for ps/top


class BackgroundLM:
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
        self._backlog: deque[NDArray[np.float64]] = deque()
        self.sent = 0
        self.dropped = 0
        self.updates = 0
        self.steps_taken = 0
        self.undone = 0
        self.ready = False  # the learner has started and waits for samples
        self._update_times: deque[float] = deque()
        # an update is due once `lm_interval` samples are sent after the learner's last
        # finished one (or its start): _mark is `sent` then, _due when the update fell due
        self._interval = settings.lm_interval
        self._mark = 0
        self._due: float | None = None
        self._process, self._to_learner, self._from_learner = (
            _PRESTARTED.pop() if _PRESTARTED else _start_learner())
        physical = hybrid.physical.to_arrays() if hybrid is not None else None
        self._to_learner.send((model, settings, physical))  # the learner waits for it
        self._closed = False

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

    def _message(self, batch: NDArray[np.float64]) -> Any:
        """A batch as sent: the array, or a hybrid's ('samples', array, θ)."""
        if self.hybrid is None:
            return batch
        return ('samples', batch, np.array(self.hybrid.physical.theta, dtype=np.float64))

    def poll(self) -> bool:
        """Take the newest weights the learner has sent, if any; return whether it had."""
        got = False
        try:
            while self._from_learner.poll():
                kind, theta, steps, *extra = self._from_learner.recv()
                self.ready = True
                if kind in ('weights', 'bounds', 'unchanged'):  # an update has finished
                    self._mark, self._due = self.sent, None
                if kind == 'weights':
                    self.model.set_theta(theta)
                    self.updates += 1
                    self.steps_taken = steps
                    self._update_times.append(time.monotonic())
                    got = True
                if extra and self.hybrid is not None:  # a hybrid's bounds, undone, gate
                    self.hybrid.bounds, self.undone, self.hybrid.gate = extra[0]
        except (EOFError, OSError):  # the learner has ended: keep the weights we have
            pass
        return got

    def wait_ready(self, timeout: float) -> bool:
        """Wait (at most ``timeout`` s) until the learner has started; return whether it
        has (samples given before are not lost either way: they wait in the pipe)."""
        deadline = time.monotonic() + timeout
        while not self.ready and self.alive and time.monotonic() < deadline:
            if self._from_learner.poll(0.05):
                self.poll()
        return self.ready

    def rate(self) -> float:
        """Updates per second over the last :data:`RATE_SPAN` s."""
        times, now = self._update_times, time.monotonic()
        while times and times[0] < now - RATE_SPAN:
            times.popleft()
        return len(times) / RATE_SPAN

    def overdue(self) -> float | None:
        """Seconds since an update fell due (``lm_interval`` samples sent since the learner's
        last finished update, or since it started) without one finishing; None if none is
        due. A hybrid's update its check undoes counts as finished."""
        return None if self._due is None else time.monotonic() - self._due

    def set_schedule(self, *, lm_interval: int, lm_steps: int) -> None:
        """Change the least samples between updates and the steps per update, from now on."""
        self._interval = int(lm_interval)
        self._send(('schedule', int(lm_interval), int(lm_steps)))

    @property
    def alive(self) -> bool:
        """Whether the learner process runs."""
        return self._process.poll() is None

    def _send(self, item: Any) -> None:
        backlog = self._backlog
        if item is not None:
            backlog.append(item)
        while backlog and self._writable():
            try:
                self._to_learner.send(backlog[0])
            except (BrokenPipeError, OSError):  # the learner has ended
                backlog.clear()
                return
            backlog.popleft()
        while len(backlog) > BACKLOG:
            dropped = backlog.popleft()
            if isinstance(dropped, np.ndarray):
                self.dropped += dropped.shape[0]
            elif dropped[0] == 'samples':
                self.dropped += dropped[1].shape[0]

    def _writable(self) -> bool:
        return bool(select.select([], [self._to_learner], [], 0)[1])

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
            self._to_learner.send(('stop',))
        except (BrokenPipeError, OSError):
            pass
        while time.monotonic() < deadline and self.alive:
            self.poll()
            time.sleep(0.005)
        self.poll()
        if self._process.poll() is None:
            self._process.terminate()
        try:
            self._process.wait(1.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._to_learner.close()
        self._from_learner.close()


_Learner = tuple[subprocess.Popen[bytes], Connection, Connection]
_PRESTARTED: list[_Learner] = []  # learner processes started ahead, waiting for a model


def _start_learner(command: str = LEARNER_COMMAND) -> _Learner:
    """Start a learner process running ``command`` (its program, given the two pipes'
    descriptors as arguments; the LM learner's by default); return it with the pipes to and
    from it.

    A fresh interpreter (not fork: the caller has DDS threads; not multiprocessing's spawn:
    it re-runs the caller's ``__main__``), with one BLAS thread of its own.
    """
    learner_reads, we_write = os.pipe()
    we_read, learner_writes = os.pipe()
    env = dict(os.environ, OPENBLAS_NUM_THREADS='1', OMP_NUM_THREADS='1',
               MKL_NUM_THREADS='1')
    process = subprocess.Popen(
        [sys.executable, '-c', command, str(learner_reads), str(learner_writes)],
        pass_fds=(learner_reads, learner_writes), env=env, stdin=subprocess.DEVNULL)
    os.close(learner_reads)
    os.close(learner_writes)
    return process, Connection(we_write, readable=False), Connection(we_read, writable=False)


def prestart(count: int) -> None:
    """Start ``count`` learner processes now, before the stream: the next
    :class:`BackgroundLM` objects take them instead of starting their own, so that the
    interpreters' start (about 0.6 s of CPU each) does not compete with the first samples.
    """
    while len(_PRESTARTED) < count:
        _PRESTARTED.append(_start_learner())


def _learner(inbox: Connection, outbox: Connection, model: FeedForwardNet,
             settings: LearnerSettings, physical: dict[str, np.ndarray] | None = None
             ) -> None:
    """The learner process: keep the reservoir, step, send weights, until told to stop.

    ``physical``: a hybrid's physical model (``PhysicalModel.to_arrays``), whose residual
    ``model`` learns through a :class:`ResidualLearner`."""
    from scara_ident_ros.blas_threads import single_blas_thread

    try:
        os.nice(settings.lm_nice)
    except OSError:
        pass
    _set_title(f'scara_ident_ros learner {settings.label}')
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the node stops it (close), not Ctrl-C
    trainer = ReservoirLM(model, reservoir_size=settings.reservoir_size,
                          lm_interval=settings.lm_interval, lm_steps=settings.lm_steps,
                          seed=settings.seed, lm_float64=settings.lm_float64,
                          lm_slow_share=settings.lm_slow_share)
    residual = None
    if physical is not None:
        from scara_ident_ros.learners.hybrid_model import HybridModel
        from scara_ident_ros.dynamics.physical_model import PhysicalModel
        from scara_ident_ros.identification.residual_learner import ResidualLearner

        hybrid = HybridModel(PhysicalModel.from_arrays(physical, source='learner'), model)
        residual = ResidualLearner(hybrid, trainer, seed=settings.seed)
    n_in = model.n_inputs
    lock = threading.Condition()
    state = {'new': 0, 'stop': False}

    def read() -> None:
        try:
            while True:
                item = inbox.recv()
                with lock:
                    if isinstance(item, np.ndarray):
                        for row in item:
                            trainer.add(row[:n_in], row[n_in:])
                        state['new'] += item.shape[0]
                    elif item[0] == 'samples' and residual is not None:
                        batch = item[1]
                        residual.add_batch(batch[:, :n_in], batch[:, n_in:])
                        residual.model.physical.theta = item[2]
                        state['new'] += batch.shape[0]
                    elif item[0] == 'schedule':
                        trainer.lm_interval, trainer.lm_steps = item[1], item[2]
                    elif item[0] == 'stop':
                        state['stop'] = True
                    lock.notify()
                if state['stop']:
                    return
        except (EOFError, OSError):  # the caller has gone
            with lock:
                state['stop'] = True
                lock.notify()

    reader = threading.Thread(target=read, name='lm-inbox', daemon=True)
    reader.start()
    try:
        outbox.send(('ready', None, 0))
    except (BrokenPipeError, OSError):  # the caller has gone already
        return
    with single_blas_thread():
        while True:
            with lock:
                while not state['stop'] and state['new'] < trainer.lm_interval:
                    lock.wait(0.5)
                # the stop takes one last update if samples came since the previous one
                if state['stop'] and not state['new']:
                    break
                last, state['new'] = state['stop'], 0
                if residual is None:
                    X, Y = (array.copy() for array in trainer.samples())
                else:
                    snap = residual.snapshot(residual.model.physical.theta)
            # every pass answers, so that the caller knows the learner keeps up
            if residual is None:
                message: tuple[Any, ...] = (
                    ('weights', model.get_theta(), trainer.steps_taken)
                    if trainer.step_on(X, Y) else ('unchanged', None, trainer.steps_taken))
            elif snap is None:  # too few validation samples yet
                message = ('unchanged', None, trainer.steps_taken)
            else:
                changed = residual.step(snap)
                message = ('weights' if changed else 'bounds',
                           model.get_theta() if changed else None, trainer.steps_taken,
                           (residual.model.bounds, residual.undone,
                            residual.model.gate.copy()))
            try:
                outbox.send(message)
            except (BrokenPipeError, OSError):
                break
            if last:
                break
    try:
        outbox.send(('stopped', None, trainer.steps_taken))
    except (BrokenPipeError, OSError):
        pass


def _set_title(title: str) -> None:
    """Name this process ``title`` in ``ps``/``top`` (Linux: its comm), if possible."""
    try:
        Path('/proc/self/comm').write_text(title[-15:])
    except OSError:
        pass


def main(argv: list[str] | None = None) -> None:
    """The learner process, started by :class:`BackgroundLM` as ``python -c
    LEARNER_COMMAND READ_FD WRITE_FD``: it waits for its model and settings."""
    args = sys.argv[1:] if argv is None else argv
    inbox = Connection(int(args[0]), writable=False)
    outbox = Connection(int(args[1]), readable=False)
    try:
        model, settings, physical = inbox.recv()
    except (EOFError, OSError):
        return
    _learner(inbox, outbox, model, settings, physical)

