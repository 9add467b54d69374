"""Affine scaling of each column to [-1, 1], like MATLAB's ``mapminmax``.

The network keeps one scaling for its inputs and one for its outputs, so that callers work
in physical units (rad, m, rad/s, N·m, N) and training works on numbers of order one. The
range mapped to [-1, 1] is each column's extremes (`MinMaxScaling.from_data`, the default)
or its mean ± k standard deviations (`MinMaxScaling.standard`, a standard score), which
outliers and rare large values do not stretch.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

__all__ = ['MinMaxScaling']

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class MinMaxScaling:
    """Map each column linearly from [lo, hi] to [-1, 1]: s = x·gain + offset.

    A column whose range is empty (lo == hi) gets gain 1 and is centred on 0, as a
    constant signal carries no information to scale.

    Parameters
    ----------
    lo, hi : ndarray of shape (n_features,)
        Physical range of each column; ``hi >= lo``, all finite.

    Attributes
    ----------
    gain, offset : ndarray of shape (n_features,)
        s = x·gain + offset and x = (s − offset) / gain.
    """

    lo: FloatArray
    hi: FloatArray
    gain: FloatArray = field(init=False, repr=False)
    offset: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        lo = np.array(self.lo, dtype=np.float64).reshape(-1)
        hi = np.array(self.hi, dtype=np.float64).reshape(-1)
        if lo.shape != hi.shape:
            raise ValueError(f'lo has {lo.size} values, hi {hi.size}')
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError('scaling ranges must be finite')
        if np.any(hi < lo):
            raise ValueError(f'scaling range with hi < lo in columns {np.flatnonzero(hi < lo)}')
        span = hi - lo
        flat = span == 0.0
        gain = np.where(flat, 1.0, 2.0 / np.where(flat, 1.0, span))
        offset = np.where(flat, -lo, -1.0 - lo * gain)
        for name, value in (('lo', lo), ('hi', hi), ('gain', gain), ('offset', offset)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @classmethod
    def identity(cls, n_features: int) -> MinMaxScaling:
        """Return the scaling that maps [-1, 1] onto itself."""
        return cls(-np.ones(n_features), np.ones(n_features))

    @classmethod
    def from_data(cls, data: npt.ArrayLike) -> MinMaxScaling:
        """Return the scaling whose range is each column's min and max in ``data``.

        Parameters
        ----------
        data : array_like of shape (n_samples, n_features)
        """
        data = np.asarray(data, dtype=np.float64)
        if data.ndim != 2 or data.shape[0] == 0:
            raise ValueError(f'need data of shape (n_samples, n_features), got {data.shape}')
        return cls(data.min(axis=0), data.max(axis=0))

    @classmethod
    def standard(cls, data: npt.ArrayLike, k: float = 1.0) -> MinMaxScaling:
        """Return the scaling that maps each column's mean ± ``k`` standard deviations to
        [-1, 1] (k = 1: the standard score, z = (x − mean) / std).

        The mean goes to 0, the centre of the range; values beyond k deviations map
        outside [-1, 1]. A constant column is centred on 0 with gain 1, as in the
        constructor.

        Parameters
        ----------
        data : array_like of shape (n_samples, n_features)
        k : float, default 1.0
            Deviations on each side of the mean that map to ±1; > 0.
        """
        data = np.asarray(data, dtype=np.float64)
        if data.ndim != 2 or data.shape[0] == 0:
            raise ValueError(f'need data of shape (n_samples, n_features), got {data.shape}')
        if not (np.isfinite(k) and k > 0.0):
            raise ValueError(f'k must be positive and finite, got {k}')
        mean, spread = data.mean(axis=0), k * data.std(axis=0)
        return cls(mean - spread, mean + spread)

    @property
    def n_features(self) -> int:
        """Number of columns scaled."""
        return int(self.lo.size)

    def transform(self, x: npt.ArrayLike) -> FloatArray:
        """Return the scaled values.

        Parameters
        ----------
        x : array_like of shape (..., n_features)
            Physical values.

        Returns
        -------
        ndarray of shape (..., n_features)
        """
        return np.asarray(x, dtype=np.float64) * self.gain + self.offset

    def inverse_transform(self, s: npt.ArrayLike) -> FloatArray:
        """Return the physical values of scaled ones; inverse of `transform`, same shapes."""
        return (np.asarray(s, dtype=np.float64) - self.offset) / self.gain
