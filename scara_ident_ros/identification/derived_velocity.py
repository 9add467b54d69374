"""Joint velocities of a recording that carries none, from its positions at their stamps.

Some recordings hold q and effort only (the TX40's, 5 kHz). Their q' is the slope, at each
sample, of a polynomial of degree ``degree`` fitted to the ``window`` positions centred on it
at their actual stamps (the fit of :class:`CentredDifferentiator`, applied to q instead of
q'): exact for positions that are polynomials of that degree, whatever the stamps, and
zero-phase for regular ones. The first and last ``window // 2`` samples of a stretch use the
stretch's first or last full window, off-centre. A stretch between two gaps shorter than the
window gets NaN (its samples are then refused as ``non_finite``).

A row that repeats the previous row exactly (a driver sending its last state again) is left
out of the fits and given the previous row's velocity, so that the input stage still sees it
as a repeat (``repeated``).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.centred_differentiator import (DIFFERENTIATOR_WINDOW,
                                                                   CentredDifferentiator)
from scara_ident_ros.identification.sample_check import DEFAULT_MAX_GAP_NS, GAP_PERIODS

__all__ = ['VELOCITY_DEGREE', 'derive_velocity']

#: Degree of the position fit: q' exact for cubic q (q'' for quadratic q', as the q'' fit).
VELOCITY_DEGREE = 3


def derive_velocity(stamp_ns: NDArray[np.int64], position: NDArray[np.float64], *,
                    effort: NDArray[np.float64] | None = None,
                    window: int = DIFFERENTIATOR_WINDOW, degree: int = VELOCITY_DEGREE,
                    max_gap_ns: int = DEFAULT_MAX_GAP_NS) -> NDArray[np.float64]:
    """q' of every sample from a centred polynomial fit of q.

    Parameters
    ----------
    stamp_ns : ndarray of shape (N,) of int64
        Increasing stamps (ns); equal stamps are left out of the fits like repeats.
    position : ndarray of shape (N, n)
        q (rad or m).
    effort : ndarray of shape (N, n), optional
        With q, what makes a row a repeat of the previous one.
    window, degree : int
        Samples per fit (odd) and the polynomial's degree.
    max_gap_ns : int
        A step longer than this and than :data:`GAP_PERIODS` median steps ends a stretch.

    Returns
    -------
    ndarray of shape (N, n)
        q' (rad/s or m/s); NaN in stretches shorter than ``window``.
    """
    stamps = np.asarray(stamp_ns, dtype=np.int64)
    q = np.asarray(position, dtype=np.float64)
    count = stamps.shape[0]
    velocity = np.full(q.shape, np.nan)
    if count == 0:
        return velocity
    same = np.zeros(count, dtype=bool)
    state = q if effort is None else np.hstack([q, np.asarray(effort, dtype=np.float64)])
    same[1:] = (np.diff(stamps) <= 0) | (state[1:] == state[:-1]).all(axis=1)
    kept = np.flatnonzero(~same)
    t, values = stamps[kept], q[kept]
    steps = np.diff(t)
    gap = max(int(max_gap_ns), GAP_PERIODS * int(np.median(steps))) if steps.size else 0
    bounds = np.concatenate(([0], np.flatnonzero(steps > gap) + 1, [t.shape[0]]))
    fit = CentredDifferentiator(window, degree)
    half = window // 2
    derived = np.full(values.shape, np.nan)
    for start, stop in zip(bounds[:-1], bounds[1:]):
        if stop - start < window:
            continue
        for i in range(int(start), int(stop)):
            first = min(max(i - half, int(start)), int(stop) - window)
            weights = fit.weights(t[first:first + window], int(i - first))
            derived[i] = (weights @ values[first:first + window])[0]
    velocity[kept] = derived
    for i in np.flatnonzero(same).tolist():  # in order: a run of repeats takes the first's value
        velocity[i] = velocity[i - 1]
    return velocity
