"""Validation samples an online identifier never learns from, and the model's error on them.

A small a-priori error on the stream shows that a model *tracks* the latest samples; it does
not show that the model has *identified* the robot. The identifier therefore holds back
whole blocks of samples (a block, not single samples: neighbouring samples at 1 kHz are
nearly equal, so single held-out samples would be learnt through their neighbours), keeps a
uniform :class:`Reservoir` of them over the whole run, and scores the *current* model on all
of them: a model that only tracks the latest motion scores badly on the held-out samples of
earlier motions, a model that identifies scores well on every one.

Blocks are counted in samples (``block``) or, by default, in time: ``block_s`` seconds of
the stream's own stamps, so that a block means the same stretch of motion whatever the
robot's rate (0.5 s: 500 samples at 1 kHz, 50 at 100 Hz; a block of 500 samples at 100 Hz
would be 5 s, and the held-out score one of few long extrapolations). The time is the
stream's progress: a step between stamps longer than a tenth of a block (a pause, a clock
jump) counts as a tenth, and a step back (a replay restarted) as nothing. (Below 20 Hz every
step is such a step, and a block holds ten samples.)

Contact detection needs more than a uniform sample: its false-alarm rate depends on how
the residuals run in time (a model error lasts several samples), so the held-out samples
are also kept as contiguous *segments* of ``segment`` samples (:class:`SegmentReservoir`,
uniform over the segments of the whole run), whose maxima are the independent draws that
:mod:`~scara_ident_ros.identification.contact_detector` calibrates on. With time blocks a
segment is at most half a block's samples, sized from the stamps of the first
:data:`RATE_SAMPLES` samples (at 1 kHz: ``segment``, 100).
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.metrics import ErrorStats, effort_errors
from scara_ident_ros.identification.reservoir import Reservoir

__all__ = ['CONTACT_SEGMENT', 'Holdout', 'MIN_VALIDATION_SAMPLES', 'RATE_SAMPLES', 'SEGMENTS',
           'SegmentReservoir', 'VALIDATION_BLOCK', 'VALIDATION_BLOCK_S', 'VALIDATION_FRACTION']

MIN_VALIDATION_SAMPLES = 100  # held-out samples before a validation NMSE is given
CONTACT_SEGMENT = 100  # samples per contiguous held-out segment (0.1 s at 1 kHz)
SEGMENTS = 200  # segments kept for contact calibration (20,000 samples by default)
#: Defaults of the node's parameters of these names
VALIDATION_FRACTION = 0.1  # of the samples, in blocks, held out
VALIDATION_BLOCK = 0  # samples per held-out block; 0: VALIDATION_BLOCK_S of the stamps
VALIDATION_BLOCK_S = 0.5  # s per held-out block when counted in time
#: Samples whose stamps give the stream's period before time blocks size the segments
RATE_SAMPLES = 10


class SegmentReservoir:
    """A uniform sample of at most ``capacity`` contiguous segments of ``length`` samples.

    Samples come in one at a time (:meth:`add`) with the index of the block they belong to;
    a segment is complete after ``length`` samples of one block, and is then offered to the
    reservoir (algorithm R over segments, the draws of a :class:`Reservoir` whose pairs are
    whole segments); a block that ends first drops its partial segment.

    Attributes
    ----------
    X : ndarray of shape (K, length, n_inputs)
    Y : ndarray of shape (K, length, n_outputs)
        The kept segments (views), K = ``len(self)``.
    blocks : ndarray of shape (K,)
        The block each kept segment comes from (segments of one block are neighbours in
        time).
    """

    def __init__(self, capacity: int, length: int, n_inputs: int, n_outputs: int, *,
                 seed: int = 0) -> None:
        if capacity < 1 or length < 1:
            raise ValueError(f'need capacity >= 1 and length >= 1, got {capacity}, {length}')
        self.capacity, self.length = int(capacity), int(length)
        self._kept = Reservoir(self.capacity, (self.length, n_inputs), (self.length, n_outputs),
                               seed=seed)
        self._blocks = np.empty(self.capacity, dtype=np.int64)
        self._stage_x = np.empty((self.length, n_inputs))
        self._stage_y = np.empty((self.length, n_outputs))
        self._fill = 0  # samples in the segment being filled
        self._block = -1  # block of the segment being filled

    def __len__(self) -> int:
        return len(self._kept)

    @property
    def count(self) -> int:
        """Complete segments offered so far."""
        return self._kept.count

    @property
    def X(self) -> NDArray[np.float64]:
        """The kept segments' inputs (a view)."""
        return self._kept.X

    @property
    def Y(self) -> NDArray[np.float64]:
        """The kept segments' outputs (a view)."""
        return self._kept.Y

    @property
    def blocks(self) -> NDArray[np.int64]:
        """The block of each kept segment (a view)."""
        return self._blocks[:len(self)]

    def add(self, block: int, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Take one held-out sample (x (n_inputs,), y (n_outputs,)) of block ``block``."""
        if block != self._block:
            self._block, self._fill = block, 0
        self._stage_x[self._fill] = x
        self._stage_y[self._fill] = y
        self._fill += 1
        if self._fill < self.length:
            return
        self._fill = 0
        slot = self._kept.offer()
        if slot >= 0:
            self._kept.put(slot, self._stage_x, self._stage_y)
            self._blocks[slot] = block


class Holdout:
    """Choose held-out blocks and score a model on a reservoir of their samples.

    ``fraction`` (in [0, 1)) of the blocks of ``block`` samples (``block`` 0: of ``block_s``
    seconds of the stamps, module docstring) are held out; ``capacity`` of their samples are
    kept to score on; ``seed`` draws the blocks and the reservoir; ``segments`` contiguous
    segments of ``min(segment, block)`` samples (time blocks: ``min(segment, half a block's
    samples)``) are kept apart for contact calibration (``segments`` 0: none).
    """

    def __init__(self, n_inputs: int, n_outputs: int, *, fraction: float = VALIDATION_FRACTION,
                 block: int = VALIDATION_BLOCK, block_s: float = VALIDATION_BLOCK_S,
                 capacity: int = 2000, seed: int = 0, segments: int = SEGMENTS,
                 segment: int = CONTACT_SEGMENT) -> None:
        if not (math.isfinite(fraction) and 0.0 <= fraction < 1.0):
            raise ValueError(f'validation fraction must be in [0, 1), got {fraction}')
        if block < 0 or (block == 0 and not (math.isfinite(block_s) and block_s > 0.0)):
            raise ValueError(f'a validation block needs block >= 1 samples, or block 0 and '
                             f'block_s > 0 s; got {block}, {block_s}')
        self.fraction = float(fraction)
        self.block = int(block)
        self.block_ns = 0 if self.block else max(1, round(block_s * 1e9))
        self.seed = int(seed)
        self.reservoir = Reservoir(capacity, n_inputs, n_outputs, seed=seed + 1)
        self._segment_shape = (segments, segment, n_inputs, n_outputs)
        self.segments: SegmentReservoir | None = None
        if self.block:
            self._make_segments(min(segment, self.block))
        self._block_index = -1
        self._held = False
        self._previous_ns: int | None = None  # time blocks: the latest stamp asked about
        self._elapsed_ns = 0  # time blocks: the stream's progress (module docstring)
        self._latest_index = 0  # time blocks: the latest index asked about

    def _make_segments(self, length: int) -> None:
        count, _, n_inputs, n_outputs = self._segment_shape
        if count > 0:
            self.segments = SegmentReservoir(count, length, n_inputs, n_outputs,
                                             seed=self.seed + 2)

    def held_out(self, index: int, stamp_ns: int | None = None) -> bool:
        """Whether the ``index``-th sample of the stream (from 0), stamped ``stamp_ns``
        (ns; needed with time blocks), is held out."""
        if self.fraction == 0.0:
            return False
        if self.block:
            block = index // self.block
        else:
            if stamp_ns is None:
                raise ValueError('time blocks (block 0) need the sample\'s stamp')
            if self._previous_ns is not None:
                self._elapsed_ns += min(max(stamp_ns - self._previous_ns, 0),
                                        self.block_ns // 10)
            self._previous_ns, self._latest_index = stamp_ns, index
            block = self._elapsed_ns // self.block_ns
        if block != self._block_index:
            self._block_index = block
            draw = np.random.default_rng([self.seed, block]).random()
            self._held = draw < self.fraction
        return self._held

    def add(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Keep a held-out sample (x (n_inputs,), y (n_outputs,)) to score on."""
        self.reservoir.add(x, y)
        if self.segments is None and not self.block:
            self._size_segments()
        if self.segments is not None:
            self.segments.add(self._block_index, x, y)

    def _size_segments(self) -> None:
        """Time blocks: make the segment store once :data:`RATE_SAMPLES` stamps give the
        period, segments of at most half a block's samples."""
        index, elapsed_ns = self._latest_index, self._elapsed_ns
        if index < RATE_SAMPLES or elapsed_ns <= 0:
            return
        period_ns = elapsed_ns / index
        self._make_segments(max(1, min(self._segment_shape[1],
                                       int(self.block_ns / period_ns) // 2)))

    def score(self, predicted: NDArray[np.float64]) -> ErrorStats | None:
        """Error statistics of predictions (K, n) of the kept samples, in their order.

        Returns None with fewer than :data:`MIN_VALIDATION_SAMPLES` samples kept.
        NMSE per joint is the MSE over the variance of that joint's held-out efforts.
        """
        if len(self.reservoir) < MIN_VALIDATION_SAMPLES:
            return None
        return effort_errors(self.reservoir.Y, predicted)
