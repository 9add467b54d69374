"""A learner as an identifier's model from the first sample: its sizes known, its
prediction defined before it has learnt anything, its state replaceable as a whole.

A kernel learner (:mod:`~scara_ident_ros.identification.learner_methods`) sets its
standardisation and kernel from its first data, so until then it has no sizes and cannot
predict; and when it learns in a process of its own, the caller's copy is replaced by each
state the process hands back. :class:`StreamedEstimator` is the one model an
:class:`~scara_ident_ros.identification.online_identifier.OnlineIdentifier` holds for it: n
joints fixed at build, the running mean of the efforts learnt so far predicted until the
learner is fitted, the learner's own ``predict``, ``partial_fit`` and ``save`` after (its
file is the learner's: :func:`~scara_ident_ros.estimator.load_model` reads it back as the
learner, which :func:`~scara_ident_ros.identification.identifier_builder.build_identifier`
wraps again for a warm start).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol, TypeVar

import numpy as np
import numpy.typing as npt

from scara_ident_ros.dynamics.joint_sizes import JointSizes
from scara_ident_ros.estimator import OnlineEstimator, r2_score

__all__ = ['ArrayLearner', 'StreamedEstimator', 'is_fitted']

FloatArray = npt.NDArray[np.float64]
_L = TypeVar('_L', bound='ArrayLearner')


class ArrayLearner(OnlineEstimator, Protocol):
    """An online estimator whose state goes through arrays (``SavedEstimator``'s): what a
    learner process hands back (:mod:`~scara_ident_ros.identification.background_estimator`)."""

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The state as named arrays."""

    @classmethod
    def from_arrays(cls: type[_L], arrays: dict[str, np.ndarray], *, source: str) -> _L:
        """The estimator of :meth:`to_arrays`' arrays."""


def is_fitted(learner: OnlineEstimator) -> bool:
    """Whether ``learner`` has sizes (has been fitted, or has learnt its first data)."""
    try:
        learner.n_outputs
    except RuntimeError:  # SavedEstimator's "learnt nothing yet"
        return False
    return True


class StreamedEstimator(JointSizes):
    """A learner of n joints' efforts that predicts from the first sample.

    Parameters
    ----------
    learner : ArrayLearner
        Fitted (a warm start) or not.
    n_joints : int
        n: the model maps 3n inputs to n efforts.

    Attributes
    ----------
    learner : ArrayLearner
        The learner of the moment (:meth:`replace` swaps it).
    fitted : bool
        Whether ``learner`` predicts; until then :meth:`predict` gives :attr:`fallback`.
    fallback : ndarray of shape (n,)
        The effort predicted before the learner is fitted (N·m, N): the running mean of the
        efforts learnt so far (:meth:`observe`), zeros at first.
    """

    def __init__(self, learner: ArrayLearner, n_joints: int) -> None:
        self.learner = learner
        self.kind = learner.kind  #: the learner's kind (its file's)
        self._n = int(n_joints)
        self.fitted = is_fitted(learner)
        if self.fitted and (learner.n_outputs, learner.n_inputs) != (self._n, 3 * self._n):
            raise ValueError(f'the {learner.kind} model maps {learner.n_inputs} inputs to '
                             f'{learner.n_outputs} efforts, not {3 * self._n} to {self._n}')
        self.fallback = np.zeros(self._n)
        self._seen = 0

    # ------------------------------------------------------------------ the learner's own
    @property
    def metadata(self) -> dict[str, np.ndarray]:
        """The learner's metadata (kept across :meth:`replace`)."""
        return self.learner.metadata

    @metadata.setter
    def metadata(self, value: dict[str, np.ndarray]) -> None:
        self.learner.metadata = value

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joints recorded in the metadata."""
        names = self.metadata.get('joint_names')
        return None if names is None else tuple(str(s) for s in np.atleast_1d(names))

    @property
    def method(self) -> str:
        """``metadata['method']``, else the learner's kind."""
        method = self.metadata.get('method')
        return self.kind if method is None else str(method)

    def get_params(self) -> dict[str, Any]:
        """The learner's hyperparameters."""
        return self.learner.get_params()

    def fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> StreamedEstimator:
        """Fit the learner on X (N, 3n), Y (N, n) (forgets what it learnt)."""
        self.learner.fit(X, Y)
        self.fitted = is_fitted(self.learner)
        return self

    def partial_fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> FloatArray:
        """The learner's ``partial_fit``: its predictions (N, n) before learning each row."""
        predicted = self.learner.partial_fit(X, Y)
        self.fitted = self.fitted or is_fitted(self.learner)
        return np.asarray(predicted, dtype=np.float64)

    def predict(self, X: npt.ArrayLike) -> FloatArray:
        """Efforts (N, n) for X (N, 3n), or (n,) for one x (3n,) (N·m, N)."""
        x = np.asarray(X, dtype=np.float64)
        rows = x[np.newaxis] if x.ndim == 1 else x
        if self.fitted:
            out = np.asarray(self.learner.predict(rows), dtype=np.float64)
        else:
            out = np.tile(self.fallback, (rows.shape[0], 1))
        return out[0] if x.ndim == 1 else out

    def score(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> float:
        """1 − mean NMSE over the joints (:func:`~scara_ident_ros.estimator.r2_score`)."""
        return r2_score(Y, self.predict(X))

    def save(self, path: str | Path) -> None:
        """Write the learner's model file.

        Raises
        ------
        OSError
            If the learner has learnt nothing yet (still gathering its first samples), or
            the file cannot be written.
        """
        if not self.fitted:
            raise OSError(f'the {self.kind} learner has learnt nothing yet (it is gathering '
                          'its first samples)')
        self.learner.save(path)

    # ------------------------------------------------------------------ the stream's
    def observe(self, Y: npt.ArrayLike) -> None:
        """Take efforts Y (N, n) to be learnt into :attr:`fallback` (their running mean)."""
        y = np.asarray(Y, dtype=np.float64).reshape(-1, self._n)
        total = self._seen + y.shape[0]
        self.fallback = self.fallback + (y.sum(axis=0) - y.shape[0] * self.fallback) / total
        self._seen = total

    def replace(self, learner: ArrayLearner) -> None:
        """Predict with ``learner`` from now on (a fitted copy of the learner: a learner
        process's latest state); the metadata stays."""
        learner.metadata = self.learner.metadata
        self.learner = learner
        self.fitted = is_fitted(learner)

    def __repr__(self) -> str:
        return f'StreamedEstimator({self.learner!r}, n_joints={self._n})'
