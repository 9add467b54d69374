"""Validation samples an online identifier never learns from, and the model's error on them.

A small a-priori error on the stream shows that a model *tracks* the latest samples; it does
not show that the model has *identified* the robot. The identifier therefore holds back
whole blocks of samples (a block, not single samples: neighbouring samples at 1 kHz are
nearly equal, so single held-out samples would be learnt through their neighbours), keeps a
uniform :class:`Reservoir` of them over the whole run, and scores the *current* model on all
of them: a model that only tracks the latest motion scores badly on the held-out samples of
earlier motions, a model that identifies scores well on every one.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.metrics import ErrorStats, effort_errors
from scara_ident_ros.identification.reservoir import Reservoir

__all__ = ['Holdout', 'MIN_VALIDATION_SAMPLES']

MIN_VALIDATION_SAMPLES = 100  # held-out samples before a validation NMSE is given


class Holdout:
    """Choose held-out blocks and score a model on a reservoir of their samples.

    ``fraction`` (in [0, 1)) of the blocks of ``block`` samples are held out; ``capacity``
    of their samples are kept to score on; ``seed`` draws the blocks and the reservoir.
    """

    def __init__(self, n_inputs: int, n_outputs: int, *, fraction: float = 0.1,
                 block: int = 500, capacity: int = 2000, seed: int = 0) -> None:
        if not (math.isfinite(fraction) and 0.0 <= fraction < 1.0):
            raise ValueError(f'validation fraction must be in [0, 1), got {fraction}')
        if block < 1:
            raise ValueError(f'validation block must be at least 1 sample, got {block}')
        self.fraction = float(fraction)
        self.block = int(block)
        self.seed = int(seed)
        self.reservoir = Reservoir(capacity, n_inputs, n_outputs, seed=seed + 1)
        self._block_index = -1
        self._held = False

    def held_out(self, index: int) -> bool:
        """Whether the ``index``-th sample of the stream (from 0) is held out."""
        block = index // self.block
        if block != self._block_index:
            self._block_index = block
            draw = np.random.default_rng([self.seed, block]).random()
            self._held = draw < self.fraction
        return self._held

    def add(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Keep a held-out sample (x (n_inputs,), y (n_outputs,)) to score on."""
        self.reservoir.add(x, y)

    def score(self, predicted: NDArray[np.float64]) -> ErrorStats | None:
        """Error statistics of predictions (K, n) of the kept samples, in their order.

        Returns None with fewer than :data:`MIN_VALIDATION_SAMPLES` samples kept.
        NMSE per joint is the MSE over the variance of that joint's held-out efforts.
        """
        if len(self.reservoir) < MIN_VALIDATION_SAMPLES:
            return None
        return effort_errors(self.reservoir.Y, predicted)
