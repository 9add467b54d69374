"""Prediction error statistics over a sliding window of the latest samples.

Per joint: the mean squared error (MSE) of the a-priori predictions over the last ``W``
samples, and the normalised MSE (NMSE): the MSE divided by the variance of that joint's
measured effort over the same samples. The NMSE is free of units and of the effort's scale,
so joints (N·m and N) and robots can be compared; NMSE = 1 is no better than predicting the
window's mean effort. NMSE is defined where the effort's variance over the samples exceeds
:data:`VARIANCE_RESOLUTION` times the squared effort scale its rounding error is relative to
(less is rounding, not motion): :func:`normalised_mse` holds that definition for every caller
(this window, ``experiments.metrics`` and ``offline.online_results``).

The paper's online figure, "the error over the last 100 samples", is ``recent(100).mse``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ['ErrorStats', 'ErrorWindow', 'PAPER_WINDOW', 'VARIANCE_RESOLUTION', 'error_stats',
           'no_error_stats', 'normalised_mse']

PAPER_WINDOW = 100  # samples: the paper's "error over the last 100 samples"
#: Variances at most this fraction of the squared effort scale are rounding: NMSE undefined.
VARIANCE_RESOLUTION = 1e-12


@dataclass(frozen=True)
class ErrorStats:
    """Error statistics over a window of samples.

    Attributes
    ----------
    mse : ndarray of shape (n_joints,)
        Mean squared prediction error per joint, (N·m)² or N²; NaN when ``count`` is 0.
    nmse : ndarray of shape (n_joints,)
        ``mse`` divided by the (population) variance of the joint's measured effort over the
        same samples; NaN where that variance is nil (see :func:`normalised_mse`).
    mse_total : float
        Mean of ``mse`` over the joints (mixing units, as the paper's figures do).
    nmse_total : float
        Mean of ``nmse`` over the joints where it is defined; NaN if it is nowhere.
    count : int
        Number of samples the statistics cover.
    """

    mse: NDArray[np.float64]
    nmse: NDArray[np.float64]
    mse_total: float
    nmse_total: float
    count: int


class ErrorWindow:
    """Sliding-window MSE and NMSE per joint, updated in O(n_joints) per sample.

    Parameters
    ----------
    n_joints : int
        Number of joints n.
    window : int
        Number of latest samples W the running statistics cover.

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

    def __init__(self, n_joints: int, window: int = 1000) -> None:
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
        """Add one sample.

        Parameters
        ----------
        effort : array_like of shape (n_joints,)
            Measured joint effort, N·m or N.
        predicted : array_like of shape (n_joints,)
            The prediction of that effort, same units.
        """
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

        Parameters
        ----------
        k : int
            Number of latest samples, at most ``window``; fewer are used while the window
            holds fewer.

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


def normalised_mse(mse: NDArray[np.float64], var: NDArray[np.float64],
                   scale: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """NMSE per joint and its mean over the joints where it is defined: the one definition.

    Parameters
    ----------
    mse, var : ndarray of shape (..., n)
        Per joint: mean squared error, and the effort's variance over the same samples.
    scale : ndarray of shape (..., n) or (n,)
        The squared effort magnitude the rounding error of ``var`` is relative to: ``var``
        itself for a two-pass variance, the mean square about the reference for running
        sums. NMSE is defined where ``var > VARIANCE_RESOLUTION * scale``.

    Returns
    -------
    nmse : ndarray of shape (..., n)
        ``mse / var``, NaN where undefined.
    nmse_total : ndarray of shape (...)
        Mean of ``nmse`` over the joints where it is defined; NaN where it is nowhere.
    """
    defined = var > VARIANCE_RESOLUTION * scale
    nmse = np.divide(mse, var, out=np.full(np.shape(mse), np.nan), where=defined)
    n_defined = defined.sum(axis=-1)
    total = np.divide(np.where(defined, nmse, 0.0).sum(axis=-1), n_defined,
                      out=np.full(np.shape(n_defined), np.nan), where=n_defined > 0)
    return nmse, total


def error_stats(mse: NDArray[np.float64], var: NDArray[np.float64], scale: NDArray[np.float64],
                count: int) -> ErrorStats:
    """:class:`ErrorStats` of ``count`` samples from per-joint arrays of shape (n,)
    (see :func:`normalised_mse`)."""
    nmse, nmse_total = normalised_mse(mse, var, scale)
    return ErrorStats(mse=mse, nmse=nmse, mse_total=float(mse.mean()),
                      nmse_total=float(nmse_total), count=count)


def no_error_stats(n_joints: int) -> ErrorStats:
    """:class:`ErrorStats` of no samples: MSE and NMSE NaN for each of ``n_joints``, count 0."""
    zeros = np.zeros(n_joints)
    return error_stats(np.full(n_joints, np.nan), zeros, zeros, 0)
