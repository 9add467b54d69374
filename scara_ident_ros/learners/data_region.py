"""Where a model was learnt: a weight that fades from 1 to 0 as inputs leave its data.

A residual learner (the hybrid's network) is fitted to the states of its training motion;
away from them it extrapolates, and a network extrapolates wildly (issue 33: a residual
network made a real arm's later motion 10-100 times worse than its physical part). The
physical part degrades gracefully there. So the hybrid scales its correction by
:meth:`DataRegion.weight`: 1 near the training inputs, 0 far from them, and the hybrid
returns to its physics on motion it has not seen.

Distance: to the nearest of up to :data:`REFERENCE_POINTS` training inputs (a seeded draw),
each input column divided by its standard deviation over the training inputs (q, q' and
q'' on one scale), by a k-d tree (:class:`scipy.spatial.cKDTree`). The radius r is the
:data:`RADIUS_QUANTILE` quantile of the same distance from held-out inputs the model was
shown to predict inside the region (``train``: the validation blocks interleaved with its
training motion; online: the validation reservoir), or without them from training inputs
*not* in the reference set, so r adapts to the data's density and dimension. (Training
inputs alone give too small a radius: along a densely sampled trajectory the next state is
always close, and on TIAGo's later motion the weight was then 0 everywhere.) The weight is
1 within r and falls linearly to 0 at :data:`FADE_END` · r:

    w(x) = clip((FADE_END · r − d(x)) / ((FADE_END − 1) · r), 0, 1)

Measured (benchmarks/fade.md, learning_curves_ur5.md): a UR5 hybrid learnt offline on one
excitation predicts other motion with NMSE 2.6 without the fade, 8e-4 (its physical part's)
with it; online, the 99th percentile and 3 r cost the UR5 hybrid nothing after 60 s
(2.3e-5 with and without) where the 95th percentile and 2 r made it 3.9 times worse. Why the
distance and not the learner's own uncertainty: the network has none, an ensemble of
networks multiplies the training time, and the distance serves any residual learner (a GP
of the residual fades by itself: its mean returns to 0 away from its data); only the
distance was measured here.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ['FADE_END', 'RADIUS_QUANTILE', 'REFERENCE_POINTS', 'DataRegion']

FloatArray = NDArray[np.float64]
#: Training inputs kept as the region's reference (a k-d tree query costs O(log M)).
REFERENCE_POINTS = 2000
#: The radius of full weight: this quantile of the training inputs' distance to the
#: reference.
RADIUS_QUANTILE = 0.99
#: The weight reaches 0 at this multiple of the radius.
FADE_END = 3.0


class DataRegion:
    """The region of input space a model was learnt on, and a weight in [0, 1] for it.

    Parameters
    ----------
    reference : array_like of shape (M, d)
        Training inputs, in the model's input units.
    scale : array_like of shape (d,)
        Each column's scale (positive): distances are taken in ``x / scale``.
    radius : float
        Distance (scaled) within which the weight is 1; it is 0 beyond
        :data:`FADE_END` · radius.
    """

    def __init__(self, reference: ArrayLike, scale: ArrayLike, radius: float) -> None:
        from scipy.spatial import cKDTree

        self.reference = np.atleast_2d(np.asarray(reference, dtype=np.float64))
        self.scale = np.asarray(scale, dtype=np.float64).reshape(-1)
        self.radius = float(radius)
        if self.scale.shape != (self.reference.shape[1],) or not np.all(self.scale > 0.0):
            raise ValueError(f'need a positive scale per column ({self.reference.shape[1]}), '
                             f'got {self.scale}')
        if self.reference.shape[0] == 0 or not self.radius > 0.0:
            raise ValueError('a data region needs reference points and a positive radius')
        self._tree = cKDTree(self.reference / self.scale)

    @classmethod
    def of(cls, X: ArrayLike, *, held_out: ArrayLike | None = None,
           points: int = REFERENCE_POINTS, seed: int = 0) -> DataRegion:
        """The region of training inputs X (N, d), N ≥ 2 (module docstring); the radius from
        ``held_out`` inputs (M, d) if given: states the model was shown to predict (its
        early-stopping samples), else from training inputs outside the reference.

        Raises
        ------
        ValueError
            With fewer than 2 samples.
        """
        from scipy.spatial import cKDTree

        x = np.atleast_2d(np.asarray(X, dtype=np.float64))
        if x.shape[0] < 2:
            raise ValueError(f'a data region needs at least 2 inputs, got {x.shape[0]}')
        std = x.std(axis=0)
        scale = np.where(std > 0.0, std, 1.0)
        order = np.random.default_rng(seed).permutation(x.shape[0])
        if held_out is not None and np.asarray(held_out).shape[0]:
            reference = x[np.sort(order[:points])]
            others = np.atleast_2d(np.asarray(held_out, dtype=np.float64))
        else:  # half the training inputs (at most ``points``) against the others
            m = min(points, x.shape[0] // 2)
            reference, others = x[np.sort(order[:m])], x[order[m:m + 4 * points]]
        distance = cKDTree(reference / scale).query(others / scale)[0]
        radius = float(np.quantile(distance, RADIUS_QUANTILE))
        if not radius > 0.0:  # repeated states: any positive radius holds them
            radius = float(np.finfo(np.float64).eps)
        return cls(reference, scale, radius)

    def distance(self, X: ArrayLike) -> FloatArray:
        """Scaled distance of each input (N, d) or (d,) to the nearest reference point:
        (N,) or ()."""
        x = np.asarray(X, dtype=np.float64)
        return np.asarray(self._tree.query(x / self.scale)[0], dtype=np.float64)

    def weight(self, X: ArrayLike) -> FloatArray:
        """The weight of each input (N, d) or (d,): 1 within the radius, 0 beyond
        :data:`FADE_END` times it, linear between; (N,) or ()."""
        d = self.distance(X)
        return np.asarray(np.clip((FADE_END * self.radius - d)
                                  / ((FADE_END - 1.0) * self.radius), 0.0, 1.0))

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The entries :meth:`from_arrays` rebuilds it from."""
        return {'reference': self.reference, 'scale': self.scale,
                'radius': np.array(self.radius)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, Any]) -> DataRegion:
        """Rebuild from :meth:`to_arrays`'s entries (``ValueError``/``KeyError`` if
        corrupt)."""
        return cls(arrays['reference'], arrays['scale'], float(arrays['radius']))
