"""Effort prediction errors: raw MSE per joint and normalised MSE.

Definitions used by every table::

    MSE_j  = mean over samples of (y_j − ŷ_j)²            (N·m)² or N²
    NMSE_j = MSE_j / var(y_j)                             var over the same samples
                                                          (population, ddof = 0)
    mse_total  = mean of MSE_j over the joints            mixes units, like the paper
    nmse_total = mean of NMSE_j over the joints where NMSE_j is defined (var(y_j) > 0)

NMSE = 1 is no better than predicting the mean effort; it is comparable across joints,
robots and data scalings, the raw MSE is not. The definitions are
:func:`~scara_ident_ros.identification.error_window.error_stats`, which
:class:`~scara_ident_ros.identification.ErrorWindow` uses too.

Public functions::

    effort_errors(Y, Y_hat) -> ErrorStats                 over all samples, vectorised
    recent_errors(Y, Y_hat, k=100) -> ErrorStats          the last k samples, through
                                                          ErrorWindow.recent(k): the online
                                                          identifier's (and paper's) figure
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from scara_ident_ros.identification import PAPER_WINDOW, ErrorStats, ErrorWindow
from scara_ident_ros.identification.error_window import error_stats, no_error_stats

__all__ = ['effort_errors', 'recent_errors']


def _check(Y: npt.ArrayLike, Y_hat: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(Y, dtype=np.float64)
    y_hat = np.asarray(Y_hat, dtype=np.float64)
    if y.ndim != 2 or y.shape != y_hat.shape:
        raise ValueError(f'Y and Y_hat must have the same shape (N, n), got {y.shape} '
                         f'and {y_hat.shape}')
    return y, y_hat


def effort_errors(Y: npt.ArrayLike, Y_hat: npt.ArrayLike) -> ErrorStats:
    """MSE and NMSE per joint over all samples (module docstring).

    Parameters
    ----------
    Y : array_like of shape (N, n)
        Measured efforts (N·m, N).
    Y_hat : array_like of shape (N, n)
        Their predictions, same units.

    Returns
    -------
    ErrorStats
        ``mse`` and ``nmse`` of shape (n,); NaN where undefined (no samples, zero variance)
        and wherever a prediction is NaN.
    """
    y, y_hat = _check(Y, Y_hat)
    if y.shape[0] == 0:
        return no_error_stats(y.shape[1])
    var = np.var(y, axis=0)
    return error_stats(np.mean((y - y_hat) ** 2, axis=0), var, var, int(y.shape[0]))


def recent_errors(Y: npt.ArrayLike, Y_hat: npt.ArrayLike,
                  k: int = PAPER_WINDOW) -> ErrorStats:
    """MSE and NMSE over the last ``k`` samples, as the online identifier reports them.

    Feeds the last ``k`` samples to an :class:`ErrorWindow` and returns its
    ``recent(k)``; ``recent_errors(Y, Y_hat, 100).mse_total`` is the paper's "error over
    the last 100 samples".

    Parameters
    ----------
    Y, Y_hat : array_like of shape (N, n)
        Measured and predicted efforts (N·m, N).
    k : int
        Window length in samples, >= 1; fewer if N < k.
    """
    y, y_hat = _check(Y, Y_hat)
    if k < 1:
        raise ValueError(f'k must be >= 1, got {k}')
    window = ErrorWindow(y.shape[1], k)
    for row, row_hat in zip(y[-k:], y_hat[-k:]):
        window.update(row, row_hat)
    return window.recent(k)
