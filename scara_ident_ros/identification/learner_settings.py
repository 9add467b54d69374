"""What a learner process is started with: its niceness and the ``lm`` learner's settings.

Apart from the process (:mod:`~scara_ident_ros.identification.lm_process`), its plumbing
(:mod:`~scara_ident_ros.identification.learner_process`) and the messages that carry these
settings (:mod:`~scara_ident_ros.identification.learner_messages`), so that each of them
imports this and none of them another one back.
"""
from __future__ import annotations

from dataclasses import dataclass

from scara_ident_ros.identification.reservoir_lm import LM_INTERVAL, LM_STEPS, RESERVOIR_SIZE

__all__ = ['LearnerSettings', 'NICE']

NICE = 10  # the learner's niceness: below the stream's processes (0), above `nice 19` jobs


@dataclass(frozen=True)
class LearnerSettings:
    """What the ``lm`` learner process builds its
    :class:`~scara_ident_ros.identification.reservoir_lm.ReservoirLM` from (see there)."""

    reservoir_size: int = RESERVOIR_SIZE
    lm_interval: int = LM_INTERVAL
    lm_steps: int = LM_STEPS
    seed: int = 0
    lm_float64: bool = False
    lm_slow_share: float = 0.0
    lm_nice: int = NICE
    label: str = 'lm'  # names the learner (e.g. the method): its process title, for ps/top
