"""The ``lm`` trainer's learner process: the reservoir and its Levenberg–Marquardt steps.

Started by :class:`~scara_ident_ros.identification.background_lm.BackgroundLM` (the caller's
end; why a process: its module docstring) as ``python -c COMMAND READ_FD WRITE_FD``. It
waits for its :class:`~scara_ident_ros.identification.learner_messages.LmStart`, keeps the
:class:`~scara_ident_ros.identification.reservoir_lm.ReservoirLM` (reservoir, slow
reservoir, LM state), takes ``lm_steps`` LM steps whenever at least ``lm_interval`` new
samples have come and answers each pass with an
:class:`~scara_ident_ros.identification.learner_messages.LmUpdate`. An update takes the
reservoir as it is when it starts; the samples that come during it count towards the next.
Without new samples there is no update (an idle stream costs no CPU); on
:class:`~scara_ident_ros.identification.learner_messages.Stop`, one last update takes the
samples that came since the previous one. The inbox is read in a thread of its own, so the
pipe is drained even during a step (:class:`~scara_ident_ros.identification.learner_process.
Inbox`).

A hybrid's network (``LmStart.physical`` given) learns through a
:class:`~scara_ident_ros.identification.residual_learner.ResidualLearner`: the residuals of
the θ each batch came with, each update checked on held-back samples, the correction bounded
and gated; its answers carry the correction's state
(:class:`~scara_ident_ros.identification.learner_messages.HybridState`).
"""
from __future__ import annotations

from multiprocessing.connection import Connection


from scara_ident_ros.identification.learner_messages import (HybridState, LmStart, LmUpdate,
                                                             Samples, Schedule, Stopped)
from scara_ident_ros.identification.learner_process import Inbox, enter_learner, run_learner
from scara_ident_ros.identification.reservoir_lm import ReservoirLM

__all__ = ['COMMAND', 'main']

#: The learner process's program: run with ``-c`` rather than ``-m``, which would import
#: this module twice (once as the package's, once as ``__main__``).
COMMAND = f'from {__name__} import main; main()'


def _learn(inbox_connection: Connection, outbox: Connection, start: LmStart) -> None:
    """The learner process: keep the reservoir, step, answer, until told to stop."""
    from scara_ident_ros.blas_threads import single_blas_thread

    model, settings = start.model, start.settings
    enter_learner(settings.lm_nice, settings.label)
    trainer = ReservoirLM(model, reservoir_size=settings.reservoir_size,
                          lm_interval=settings.lm_interval, lm_steps=settings.lm_steps,
                          seed=settings.seed, lm_float64=settings.lm_float64,
                          lm_slow_share=settings.lm_slow_share)
    residual = None
    if start.physical is not None:
        from scara_ident_ros.dynamics.physical_model import PhysicalModel
        from scara_ident_ros.identification.residual_learner import ResidualLearner
        from scara_ident_ros.learners.hybrid_model import HybridModel

        hybrid = HybridModel(PhysicalModel.from_arrays(start.physical, source='learner'),
                             model)
        residual = ResidualLearner(hybrid, trainer, seed=settings.seed)
    n_in = model.n_inputs

    def take(message: object) -> int:  # under the inbox's lock
        if isinstance(message, Samples):
            batch = message.rows
            if residual is None:
                for row in batch:
                    trainer.add(row[:n_in], row[n_in:])
            elif message.theta is not None:  # a hybrid's batch has its θ
                residual.add_batch(batch[:, :n_in], batch[:, n_in:])
                residual.model.physical.theta = message.theta
            return int(batch.shape[0])
        if isinstance(message, Schedule):
            trainer.lm_interval, trainer.lm_steps = message.lm_interval, message.lm_steps
        return 0

    inbox = Inbox(inbox_connection, take)
    if not inbox.start(outbox, 'lm-inbox'):
        return
    with single_blas_thread():
        while True:
            with inbox.lock:
                while not inbox.stopped and inbox.new < trainer.lm_interval:
                    inbox.lock.wait(0.5)
                # the stop takes one last update if samples came since the previous one
                if inbox.stopped and not inbox.new:
                    break
                last, inbox.new = inbox.stopped, 0
                if residual is None:
                    X, Y = (array.copy() for array in trainer.samples())
                else:
                    snap = residual.snapshot(residual.model.physical.theta)
            # every pass answers, so that the caller knows the learner keeps up
            if residual is None:
                changed = trainer.step_on(X, Y)
                answer = LmUpdate(model.get_theta() if changed else None,
                                  trainer.steps_taken)
            elif snap is None:  # too few validation samples yet: the correction as it was
                answer = LmUpdate(None, trainer.steps_taken)
            else:
                changed = residual.step(snap)
                answer = LmUpdate(model.get_theta() if changed else None,
                                  trainer.steps_taken,
                                  HybridState(residual.model.bounds, residual.undone,
                                              residual.model.gate.copy(),
                                              None if residual.model.region is None else
                                              residual.model.region.to_arrays()))
            try:
                outbox.send(answer)
            except (BrokenPipeError, OSError):
                break
            if last:
                break
    try:
        outbox.send(Stopped(trainer.steps_taken))
    except (BrokenPipeError, OSError):
        pass


def main(argv: list[str] | None = None) -> None:
    """The learner process (:data:`COMMAND` READ_FD WRITE_FD): waits for its
    :class:`~scara_ident_ros.identification.learner_messages.LmStart`."""
    run_learner(_learn, argv)
