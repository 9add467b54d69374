"""A check shared by the excitation tests: sampled q, q', q'' without a jump."""
from __future__ import annotations

import numpy as np


def assert_consistent(t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                      rtol: float = 1e-3) -> None:
    """q' and q'' are the derivatives of q and q' (trapezoidal rule between samples, to
    ``rtol`` of the largest change one sample period could make): no jump in q, q' or q''."""
    dt = np.diff(t)[:, None]
    for x, dx in ((q, qd), (qd, qdd)):
        step = np.diff(x, axis=0)
        trapezoid = 0.5 * (dx[1:] + dx[:-1]) * dt
        scale = np.abs(dx).max(axis=0) * dt.max()
        assert np.all(np.abs(step - trapezoid) <= rtol * scale + 1e-12), (
            f'jump: {np.abs(step - trapezoid).max(axis=0)} vs {rtol * scale}')
