"""Sample times of a real-time loop that wakes up a little early or late: jittered stamps.

A ros2_control ``joint_state_broadcaster`` stamps each sample with the time the controller
manager's loop read the hardware. The loop runs against absolute deadlines ``k / rate``, so
the stamps do not drift, but each is off its deadline by the loop's wake-up jitter. Here
sample ``k`` is stamped

    t_k = k · T + e_k,    e_k ~ N(0, jitter²) clipped to ±min(3 jitter, 0.45 T),

independent draws around the nominal times: the mean period stays ``T``, two stamps are
always at least ``0.1 T`` apart and in order. The first stamp is exactly 0 (``e_0 = 0``):
the loop's time zero, where a trajectory starts. The draws are seeded and random-access (one
generator per block of samples), so a stamp is the same whichever way it is asked for.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ['StampJitter', 'MAX_JITTER_FRACTION']

#: Largest jitter standard deviation, as a fraction of the period.
MAX_JITTER_FRACTION = 0.5
_CLIP_SIGMAS = 3.0  # offsets are clipped at this many standard deviations ...
_CLIP_PERIOD = 0.45  # ... and at this fraction of the period, so that stamps stay in order
_BLOCK = 1024  # samples per seeded block of offsets


class StampJitter:
    """Jittered sample stamps ``k · period_ns + e_k`` (module docstring).

    Parameters
    ----------
    period_ns : int
        Nominal sample period T (ns), > 0.
    jitter : float
        Standard deviation of the offsets e_k (s), in [0, 0.5 T]; 0 gives ``k · period_ns``.
    seed : int
        Seed of the offsets, >= 0.
    """

    def __init__(self, period_ns: int, jitter: float, *, seed: int = 0) -> None:
        if period_ns <= 0:
            raise ValueError(f'period_ns must be positive, got {period_ns}')
        if not 0.0 <= jitter <= MAX_JITTER_FRACTION * period_ns * 1e-9:
            raise ValueError(f'jitter must be in [0, {MAX_JITTER_FRACTION:g} period] = '
                             f'[0, {MAX_JITTER_FRACTION * period_ns * 1e-9:g}] s, got '
                             f'{jitter!r}')
        self.period_ns = int(period_ns)
        self.jitter = float(jitter)
        self.seed = int(seed)
        self._clip_ns = min(_CLIP_SIGMAS * self.jitter * 1e9, _CLIP_PERIOD * period_ns)
        self._block = -1
        self._offsets = np.zeros(_BLOCK, dtype=np.int64)

    def stamp_ns(self, k: int) -> int:
        """Stamp of sample ``k`` >= 0 (ns)."""
        if self.jitter == 0.0:
            return k * self.period_ns
        block, index = divmod(k, _BLOCK)
        if block != self._block:
            self._offsets = self._draw(block)
            self._block = block
        return k * self.period_ns + int(self._offsets[index])

    def stamps_ns(self, start: int, count: int) -> NDArray[np.int64]:
        """Stamps of samples ``start .. start + count - 1``, shape (count,), int64 (ns)."""
        k = start + np.arange(count, dtype=np.int64)
        stamps = k * self.period_ns
        if self.jitter == 0.0 or count == 0:
            return stamps
        first, last = start // _BLOCK, (start + count - 1) // _BLOCK
        offsets = np.concatenate([self._draw(b) for b in range(first, last + 1)])
        return stamps + offsets[start - first * _BLOCK:][:count]

    def _draw(self, block: int) -> NDArray[np.int64]:
        """The offsets of one block of samples (ns), from its own seeded generator."""
        rng = np.random.default_rng([self.seed, block])
        draws = rng.standard_normal(_BLOCK) * (self.jitter * 1e9)  # ns
        offsets = np.rint(np.clip(draws, -self._clip_ns, self._clip_ns)).astype(np.int64)
        if block == 0:
            offsets[0] = 0
        return offsets
