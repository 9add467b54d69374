"""Prediction error statistics over a sliding window of the latest samples.

MSE and NMSE per joint over the last ``W`` a-priori predictions, as defined in
:mod:`~scara_ident_ros.identification.metrics`. The paper's online figure, "the error over
the last 100 samples", is ``recent(100).mse``.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.identification.metrics import (ErrorStats, check_pair, error_stats,
                                                    no_error_stats)

__all__ = ['ErrorWindow', 'MSE_WINDOW', 'PAPER_WINDOW', 'recent_errors']

PAPER_WINDOW = 100  # samples: the paper's "error over the last 100 samples"
MSE_WINDOW = 1000  # samples: the identifier's windowed MSE (the node's ``mse_window``)


class ErrorWindow:
    """Sliding-window MSE and NMSE per joint, updated in O(n_joints) per sample.

    ``window`` is the number W of latest samples the running statistics cover.

    Notes
    -----
    Running sums of the squared errors and of the effort's first two moments are updated
    per sample (add the new sample, subtract the one leaving the window) and recomputed
    exactly from the ring buffer each time it wraps, so rounding drift cannot build up: the
    cost is O(W n) once per W samples, O(n) amortised. The effort moments are taken about a
    reference effort (the first sample's, then the window mean at each recompute), so the
    variance does not cancel catastrophically when an effort has a large mean, such as a
    gravity load.
    """

    def __init__(self, n_joints: int, window: int = MSE_WINDOW) -> None:
        if n_joints < 1 or window < 1:
            raise ValueError(f'need n_joints >= 1 and window >= 1, got {n_joints}, {window}')
        self.n_joints = int(n_joints)
        self.window = int(window)
        # Ring buffer, one row per sample: squared error, effort - ref, (effort - ref) ** 2.
        self._rows = np.zeros((self.window, 3, self.n_joints))
        self.reset()

    @property
    def count(self) -> int:
        """Number of samples in the window, at most ``window``."""
        return self._count

    def reset(self) -> None:
        """Empty the window."""
        self._rows[:] = 0.0  # a zero row leaving the window subtracts nothing
        self._sums = np.zeros((3, self.n_joints))
        self._ref: NDArray[np.float64] | None = None  # effort the moments are taken about
        self._count = 0
        self._head = 0  # ring slot the next sample goes to

    def update(self, effort: ArrayLike, predicted: ArrayLike) -> None:
        """Add one sample: measured ``effort`` (n_joints,) (N·m or N) and its prediction."""
        y = np.asarray(effort, dtype=np.float64)
        if self._ref is None:
            self._ref = y.copy()
        row = self._rows[self._head]
        self._sums -= row
        error = np.subtract(y, predicted)
        np.multiply(error, error, out=row[0])
        np.subtract(y, self._ref, out=row[1])
        np.multiply(row[1], row[1], out=row[2])
        self._sums += row
        self._count = min(self._count + 1, self.window)
        self._head += 1
        if self._head == self.window:
            self._head = 0
            self._recompute()

    def snapshot(self) -> ErrorStats:
        """Return the statistics over the whole window (the last ``count`` samples)."""
        c = self._count
        if c == 0:
            return no_error_stats(self.n_joints)
        mse, mean, mean_sq = self._sums / c  # rounding may leave sums of squares at -0
        return error_stats(np.maximum(mse, 0.0), np.maximum(mean_sq - mean * mean, 0.0),
                           mean_sq, c)

    def recent(self, k: int = PAPER_WINDOW) -> ErrorStats:
        """Return the statistics over the last ``k`` samples, computed exactly, O(k n).

        Fewer than ``k`` are used while the window holds fewer.

        Raises
        ------
        ValueError
            If ``k`` is not in 1..window.
        """
        if not 1 <= k <= self.window:
            raise ValueError(f'k must be in 1..{self.window}, got {k}')
        k = min(k, self._count)
        if k == 0:
            return no_error_stats(self.n_joints)
        rows = self._rows[np.arange(self._head - k, self._head) % self.window]
        var = rows[:, 1].var(axis=0)
        return error_stats(rows[:, 0].mean(axis=0), var, var, k)

    def _recompute(self) -> None:
        """Re-centre the (full) ring buffer on its mean effort and recompute the sums."""
        assert self._ref is not None
        shift = self._rows[:, 1].mean(axis=0)
        self._ref = self._ref + shift
        self._rows[:, 1] -= shift
        np.multiply(self._rows[:, 1], self._rows[:, 1], out=self._rows[:, 2])
        self._sums = self._rows.sum(axis=0)


def recent_errors(Y: npt.ArrayLike, Y_hat: npt.ArrayLike,
                  k: int = PAPER_WINDOW) -> ErrorStats:
    """MSE and NMSE over the last ``k`` samples, as the online identifier reports them.

    ``Y``, ``Y_hat`` (N, n) are measured and predicted efforts (N·m, N); ``k`` >= 1 (fewer
    if N < k).
    """
    y, y_hat = check_pair(Y, Y_hat)
    if k < 1:
        raise ValueError(f'k must be >= 1, got {k}')
    window = ErrorWindow(y.shape[1], k)
    for row, row_hat in zip(y[-k:], y_hat[-k:]):
        window.update(row, row_hat)
    return window.recent(k)
