"""A fixed-size uniform sample of an endless stream (reservoir sampling, algorithm R).

After ``count`` samples have been offered, each of them is in the reservoir with the same
probability ``capacity / count``, whatever the order: a bounded memory that keeps
representing the whole history, which a window of the latest samples does not (a window
of one motion teaches a network that motion only).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ['RESERVOIR_SIZE', 'Reservoir']

#: Samples of the stream a learner keeps by default: the node's ``reservoir_size`` (for the
#: ``lm`` trainer, and the kernel learners' refits).
RESERVOIR_SIZE = 4000


class Reservoir:
    """Keep a uniform random sample of at most ``capacity`` (x, y) pairs.

    Parameters
    ----------
    capacity : int
        Most pairs kept, at least 1.
    n_inputs, n_outputs : int or tuple of int
        Lengths of x and y, or their shapes (a :class:`~.holdout.SegmentReservoir` keeps each
        segment of shape (length, n_inputs) as one x).
    seed : int
        Seed of the replacement draws.
    """

    def __init__(self, capacity: int, n_inputs: int | tuple[int, ...],
                 n_outputs: int | tuple[int, ...], *, seed: int = 0) -> None:
        if capacity < 1:
            raise ValueError(f'capacity must be at least 1, got {capacity}')
        self.capacity = int(capacity)
        self._x = np.empty((self.capacity, *np.atleast_1d(n_inputs)))
        self._y = np.empty((self.capacity, *np.atleast_1d(n_outputs)))
        self._rng = np.random.default_rng(seed)
        self.count = 0  # pairs offered so far

    def __len__(self) -> int:
        return min(self.count, self.capacity)

    @property
    def X(self) -> NDArray[np.float64]:
        """The kept inputs, shape (len(self), *n_inputs) (a view: do not keep it)."""
        return self._x[:len(self)]

    @property
    def Y(self) -> NDArray[np.float64]:
        """The kept outputs, shape (len(self), *n_outputs) (a view: do not keep it)."""
        return self._y[:len(self)]

    def add(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> bool:
        """Offer one pair; return whether it was kept.

        Parameters
        ----------
        x : ndarray of shape (n_inputs,) (or the shape given)
        y : ndarray of shape (n_outputs,) (or the shape given)
        """
        slot = self.offer()
        if slot < 0:
            return False
        self.put(slot, x, y)
        return True

    def offer(self) -> int:
        """Count one pair offered; return the slot it goes in (:meth:`put`), or -1 if it
        is not kept (the same draw as :meth:`add`: a caller can skip computing a pair that
        would not be kept)."""
        count = self.count
        self.count = count + 1
        if count < self.capacity:
            return count
        slot = int(self._rng.random() * (count + 1))  # uniform in 0..count
        return slot if slot < self.capacity else -1

    def put(self, slot: int, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Store a pair in ``slot`` (from :meth:`offer`)."""
        self._x[slot] = x
        self._y[slot] = y

    def clear(self) -> None:
        """Forget every pair."""
        self.count = 0
