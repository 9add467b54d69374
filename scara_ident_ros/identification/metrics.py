"""Effort prediction errors: MSE and normalised MSE (NMSE) per joint, the one definition.

Definitions used by the online identifier, its hold-out, every table and benchmark::

    MSE_j  = mean over samples of (y_j − ŷ_j)²            (N·m)² or N²
    NMSE_j = MSE_j / var(y_j)                             var over the same samples
                                                          (population, ddof = 0)
    mse_total  = mean of MSE_j over the joints            mixes units, like the paper
    nmse_total = mean of NMSE_j over the joints where NMSE_j is defined
    smse       = Σ_j MSE_j / Σ_j var(y_j)                 over the same joints: the squared
                                                          errors of all joints over their
                                                          squared deviations (1 − R²,
                                                          variance-weighted; the published
                                                          figure of the GP benchmarks)

NMSE = 1 is no better than predicting the mean effort; it is comparable across joints,
robots and data scalings, the raw MSE is not. NMSE_j is defined where the effort's variance
exceeds :data:`VARIANCE_RESOLUTION` times the squared effort scale its rounding error is
relative to (less is rounding, not motion).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

__all__ = ['ErrorStats', 'VARIANCE_RESOLUTION', 'effort_errors', 'error_stats',
           'no_error_stats', 'normalised_mse']

#: Variances at most this fraction of the squared effort scale are rounding: NMSE undefined.
VARIANCE_RESOLUTION = 1e-12


@dataclass(frozen=True)
class ErrorStats:
    """Error statistics over a set of samples.

    Attributes
    ----------
    mse, nmse : ndarray of shape (n_joints,)
        Per joint, as defined in the module docstring; NaN where undefined.
    mse_total, nmse_total : float
        Their means over the joints (module docstring).
    smse : float
        Standardised MSE of all joints together (module docstring); NaN where no NMSE is.
    count : int
        Number of samples the statistics cover.
    """

    mse: NDArray[np.float64]
    nmse: NDArray[np.float64]
    mse_total: float
    nmse_total: float
    count: int
    smse: float


def normalised_mse(mse: NDArray[np.float64], var: NDArray[np.float64],
                   scale: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """NMSE per joint and its mean over the joints where it is defined.

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
    defined = var > VARIANCE_RESOLUTION * scale
    smse = float(mse[defined].sum() / var[defined].sum()) if defined.any() else np.nan
    return ErrorStats(mse=mse, nmse=nmse, mse_total=float(mse.mean()),
                      nmse_total=float(nmse_total), count=count, smse=smse)


def no_error_stats(n_joints: int) -> ErrorStats:
    """:class:`ErrorStats` of no samples: MSE and NMSE NaN for each of ``n_joints``, count 0."""
    zeros = np.zeros(n_joints)
    return error_stats(np.full(n_joints, np.nan), zeros, zeros, 0)


def check_pair(Y: npt.ArrayLike, Y_hat: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """``Y`` and ``Y_hat`` as float arrays of one shape (N, n); ValueError otherwise."""
    y = np.asarray(Y, dtype=np.float64)
    y_hat = np.asarray(Y_hat, dtype=np.float64)
    if y.ndim != 2 or y.shape != y_hat.shape:
        raise ValueError(f'Y and Y_hat must have the same shape (N, n), got {y.shape} '
                         f'and {y_hat.shape}')
    return y, y_hat


def effort_errors(Y: npt.ArrayLike, Y_hat: npt.ArrayLike) -> ErrorStats:
    """MSE and NMSE per joint over all samples (module docstring).

    ``Y``, ``Y_hat`` (N, n) are measured and predicted efforts (N·m, N); the result is NaN
    where undefined (no samples, zero variance) and wherever a prediction is NaN.
    """
    y, y_hat = check_pair(Y, Y_hat)
    if y.shape[0] == 0:
        return no_error_stats(y.shape[1])
    var = np.var(y, axis=0)
    return error_stats(np.mean((y - y_hat) ** 2, axis=0), var, var, int(y.shape[0]))
