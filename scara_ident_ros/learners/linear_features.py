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

    def __init__(self) -> None:
        self.metadata: dict[str, np.ndarray] = {}
        self.coef_ = np.zeros((0, 0))

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
        scale = np.abs(features).max(axis=0)
        scale[scale == 0.0] = 1.0
        coef, *_ = np.linalg.lstsq(features / scale, y, rcond=None)
        self.coef_ = coef / scale[:, None]
        self.n_inputs_, self.n_outputs_ = x.shape[1], y.shape[1]
        return self

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
        return {'coef': self.coef_}

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
        return model

    def _need_ready(self) -> None:
        if not self.coef_.size:
            raise RuntimeError('the model has learnt nothing yet: call fit')

    def __repr__(self) -> str:
        state = f'{self.n_inputs_}->{self.n_outputs_}' if self.coef_.size else 'unfitted'
        return f'LinearFeatures({state})'


register_kind(KIND, LinearFeatures.load)  # load(path) -> the model
