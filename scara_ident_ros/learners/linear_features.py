"""Linear least squares on simple features of each sample: the baseline every learner must beat.

Each joint's effort is fitted, in closed form, as a linear function of the features

    [q, q', q'', sin q, cos q, tanh(q' / 0.05), 1]    (all joints' q, q', q'' and the
                                                         trigonometric and friction terms)

which take inertia about a fixed pose, gravity of a single link, viscous and smoothed
Coulomb friction and an effort offset. It needs no URDF and no iterations, and on some real
recordings no learner here beats it (TIAGo: docs/results.md), so ``scara-ident train
--method auto`` weighs it against the learners on the validation blocks. It is also the
reference row of ``scara-ident compare --recording``
(:mod:`~scara_ident_ros.paper.linear_reference`) and issue 25's TIAGo baseline.

It also learns online (``partial_fit``, the identifier's ``method: linear``): it keeps the
triangular factor R (at most p × p) of the QR decomposition of every feature row learnt and
Q'Y, updates them by the QR of [R; new rows] and solves after each call, so that after any
sequence of calls it holds the batch solution on all samples so far (:meth:`LinearFeatures.fit`'s
up to rounding: the factor, unlike the normal equations F'F, keeps the directions a short
stretch of motion barely excites, as ``lstsq`` on every row does), at O(p²) per sample and
O(p³) per call (p = 6n + 1: 43 for 7 joints), well within 1 ms.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from scara_ident_ros.estimator import SavedEstimator, check_samples, register_kind
from scara_ident_ros.nn.errors import ModelFormatError

__all__ = ['COULOMB_VELOCITY', 'KIND', 'LinearFeatures', 'linear_features']

KIND = 'linear'  #: the model file's kind
COULOMB_VELOCITY = 0.05  # rad/s or m/s: the velocity scale of the smoothed Coulomb term


def linear_features(X: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Features (N, 6n + 1) of samples X (N, 3n) = [q, q', q''] (rad or m, /s, /s²)."""
    x = np.asarray(X, dtype=np.float64)
    n = x.shape[1] // 3
    q, qd = x[:, :n], x[:, n:2 * n]
    return np.hstack([x, np.sin(q), np.cos(q), np.tanh(qd / COULOMB_VELOCITY),
                      np.ones((x.shape[0], 1))])


class LinearFeatures(SavedEstimator):
    """Least squares (minimum norm) of the efforts on :func:`linear_features`.

    The feature columns are scaled by their largest magnitude for the conditioning and the
    coefficients scaled back, so the fit does not depend on the joints' units.

    Attributes
    ----------
    coef_ : ndarray of shape (6n + 1, n)
        Coefficients of the features, per joint (effort units per feature unit).
    n_inputs_, n_outputs_ : int
        3n and n, set by :meth:`fit`.
    metadata : dict of str to ndarray
        Saved with the model (joint names, method, ...).
    """

    kind = KIND
    #: ``partial_fit`` holds the batch solution on every sample learnt: a stream never
    #: refits it (:mod:`~scara_ident_ros.identification.learner_stream`).
    exact_online = True

    def __init__(self) -> None:
        self.metadata: dict[str, np.ndarray] = {}
        self.coef_ = np.zeros((0, 0))
        # R and Q'Y of the QR decomposition of every feature row learnt (fit or
        # partial_fit), each feature's largest magnitude (the solve's column scaling) and
        # the rows learnt (the solve's rcond, as lstsq's on all rows)
        self._factor = np.zeros((0, 0))
        self._projected = np.zeros((0, 0))
        self._feature_max = np.zeros(0)
        self.n_seen_ = 0

    def get_params(self) -> dict[str, Any]:
        """No hyperparameters: the features are fixed."""
        return {}

    def fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> LinearFeatures:
        """Fit the coefficients to samples X (N, 3n) and efforts Y (N, n).

        Raises
        ------
        ValueError
            If X's columns are not a multiple of 3, or for the shapes and values that
            :func:`~scara_ident_ros.estimator.check_samples` refuses.
        """
        x, y = check_samples(X, Y)
        if x.shape[1] % 3:
            raise ValueError(f'X must have 3n columns [q, q\', q\'\'], got {x.shape[1]}')
        features = linear_features(x)
        self._reset(features.shape[1], y.shape[1])
        self._learn(features, y)
        self.n_inputs_, self.n_outputs_ = x.shape[1], y.shape[1]
        return self

    def partial_fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Predict samples X (N, 3n), then learn them with their efforts Y (N, n): the
        coefficients become the least-squares solution on every sample learnt so far.

        Returns
        -------
        ndarray of shape (N, n)
            The predictions made before learning the call's samples (N·m, N); zeros in a
            model's first call.

        Raises
        ------
        ValueError
            As :meth:`fit`, or for samples of other sizes than those learnt before.
        """
        first = not self.coef_.size
        x, y = check_samples(X, Y, None if first else (self.n_inputs_, self.n_outputs_))
        if x.shape[1] % 3:
            raise ValueError(f'X must have 3n columns [q, q\', q\'\'], got {x.shape[1]}')
        features = linear_features(x)
        predicted = np.zeros_like(y) if first else features @ self.coef_
        if not self._feature_max.size:  # a first call, or a model read from an older file
            self._reset(features.shape[1], y.shape[1])
        self._learn(features, y)
        self.n_inputs_, self.n_outputs_ = x.shape[1], y.shape[1]
        return np.asarray(predicted, dtype=np.float64)

    def _reset(self, p: int, n: int) -> None:
        """Forget every sample: p features, n joints."""
        self._factor, self._projected = np.zeros((0, p)), np.zeros((0, n))
        self._feature_max, self.n_seen_ = np.zeros(p), 0

    def _learn(self, features: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> None:
        """Fold feature rows (N, p) and efforts (N, n) into R and Q'Y, and solve: the
        minimum-norm least-squares coefficients on every row so far, the columns scaled by
        their largest magnitude (so the solution does not depend on the joints' units) and
        rcond that of ``lstsq`` on all the rows."""
        q, self._factor = np.linalg.qr(np.vstack([self._factor, features]))
        self._projected = q.T @ np.vstack([self._projected, y])
        np.maximum(self._feature_max, np.abs(features).max(axis=0), out=self._feature_max)
        self.n_seen_ += features.shape[0]
        scale = np.where(self._feature_max > 0.0, self._feature_max, 1.0)
        coef, *_ = np.linalg.lstsq(self._factor / scale, self._projected,
                                   rcond=np.finfo(np.float64).eps
                                   * max(self.n_seen_, scale.size))
        self.coef_ = coef / scale[:, None]

    def predict(self, X: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Efforts (N, n) of samples X (N, 3n)."""
        self._need_ready()
        x = np.asarray(X, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_inputs_:
            raise ValueError(f'X must have shape (N, {self.n_inputs_}), got {x.shape}')
        return np.asarray(linear_features(x) @ self.coef_, dtype=np.float64)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The entries :meth:`from_arrays` rebuilds the model from."""
        self._need_ready()
        arrays: dict[str, np.ndarray] = {'coef': self.coef_}
        if self._feature_max.size:  # what partial_fit goes on from
            arrays.update(factor=self._factor, projected=self._projected,
                          feature_max=self._feature_max, n_seen=np.array(self.n_seen_))
        return arrays

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], *, source: str) -> LinearFeatures:
        """Rebuild a model from :meth:`to_arrays`' entries.

        Raises
        ------
        ModelFormatError
            If ``coef`` is missing or not a finite float64 array of shape (6n + 1, n).
        """
        coef = arrays.get('coef')
        if coef is None or coef.dtype != np.float64 or coef.ndim != 2 \
                or (coef.shape[0] - 1) % 6 or coef.shape[0] < 7 \
                or not np.all(np.isfinite(coef)):
            raise ModelFormatError(f'{source}: not a linear model (need finite float64 coef '
                                   'of shape (6n + 1, n))')
        model = cls()
        model.coef_ = np.array(coef)
        model.n_inputs_, model.n_outputs_ = 3 * ((coef.shape[0] - 1) // 6), coef.shape[1]
        p, n = coef.shape
        if all(name in arrays for name in ('factor', 'projected', 'feature_max', 'n_seen')):
            factor, projected = np.asarray(arrays['factor']), np.asarray(arrays['projected'])
            feature_max = np.asarray(arrays['feature_max'])
            k = factor.shape[0] if factor.ndim == 2 else -1
            if not (0 <= k <= p and factor.shape == (k, p) and projected.shape == (k, n)
                    and feature_max.shape == (p,)) \
                    or not all(a.dtype == np.float64 and np.all(np.isfinite(a))
                               for a in (factor, projected, feature_max)):
                raise ModelFormatError(f'{source}: a linear model\'s factor, projected and '
                                       f'feature_max must be finite float64 of shapes (k, '
                                       f'{p}), (k, {n}) and ({p},), k <= {p}')
            model._factor, model._projected = np.array(factor), np.array(projected)
            model._feature_max = np.array(feature_max)
            model.n_seen_ = int(arrays['n_seen'])
        return model

    def _need_ready(self) -> None:
        if not self.coef_.size:
            raise RuntimeError('the model has learnt nothing yet: call fit')

    def __repr__(self) -> str:
        state = f'{self.n_inputs_}->{self.n_outputs_}' if self.coef_.size else 'unfitted'
        return f'LinearFeatures({state})'


register_kind(KIND, LinearFeatures.load)  # load(path) -> the model
