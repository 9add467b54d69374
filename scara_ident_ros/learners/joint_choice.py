"""Per joint, the model that predicted later motion best: what ``scara-ident train`` chooses.

No learner wins on every joint of a real arm: on the TX40's later motion the physical model
is best on most joints, linear least squares on a wrist joint; on TIAGo the GP on some and
FFS on others (benchmarks/later_motion.md). :class:`JointChoice` holds the candidates that
won a joint and predicts each joint with its own. :func:`choose_joints` decides: the
candidate of the lowest mean squared error on held-out later motion, except that a
*default* (the physical model, with a URDF) is kept on a joint unless another candidate's
error there is at most :data:`MARGIN` times its own on each part of the later motion
(``scara-ident train``: its two halves in time): a few seconds of later motion rank models
only roughly, and the physical model degrades more gracefully on motion further away. On
TIAGo one half of the later motion made linear least squares look 2.7 times better than
the physical model on arm_3, which then predicted the motion after it 1.4 times worse.

Files: kind ``'joint_choice'``; each kept candidate's entries prefixed ``<label>.`` with its
kind in ``<label>.kind``; the labels in ``labels`` and the label of each joint in
``choice``.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.estimator import Estimator, SavedEstimator, register_kind
from scara_ident_ros.learners.exact_gp import ExactGP
from scara_ident_ros.learners.hybrid_model import HybridModel
from scara_ident_ros.learners.linear_features import LinearFeatures
from scara_ident_ros.learners.sparse_spectrum_gp import SparseSpectrumGP
from scara_ident_ros.nn import FeedForwardNet, ModelFormatError

__all__ = ['KIND', 'MARGIN', 'JointChoice', 'choose_joints']

FloatArray = NDArray[np.float64]
KIND = 'joint_choice'  #: the model file's kind
#: Another candidate replaces the default on a joint if its later-motion MSE is at most this
#: share of the default's.
MARGIN = 0.8

#: How a candidate is rebuilt from its entries, by kind.
_FROM_ARRAYS: dict[str, Callable[[dict[str, np.ndarray], str], Any]] = {
    PhysicalModel.kind: lambda a, s: PhysicalModel.from_arrays(a, source=s),
    LinearFeatures.kind: lambda a, s: LinearFeatures.from_arrays(a, source=s),
    ExactGP.kind: lambda a, s: ExactGP.from_arrays(a, source=s),
    SparseSpectrumGP.kind: lambda a, s: SparseSpectrumGP.from_arrays(a, source=s),
    HybridModel.kind: lambda a, s: HybridModel.from_arrays(a, source=s),
    FeedForwardNet.kind: lambda a, s: FeedForwardNet.from_arrays(a)}


def choose_joints(errors: Mapping[str, ArrayLike], default: str | None = None, *,
                  margin: float = MARGIN) -> list[str]:
    """The candidate of each joint (module docstring).

    Parameters
    ----------
    errors : mapping of str to array_like of shape (n,) or (k, n)
        Each candidate's mean squared error per joint on held-out later motion (finite), or
        on each of k parts of it (e.g. its two halves in time).
    default : str, optional
        A candidate kept on a joint unless another's error is at most ``margin`` times its,
        on every part.
    margin : float
        In (0, 1].

    Returns
    -------
    list of str
        A label per joint: the default's, or the candidate of the lowest mean error over
        the parts among those that beat it so.
    """
    labels = list(errors)
    table = np.array([np.atleast_2d(np.asarray(errors[label], dtype=np.float64))
                      for label in labels])  # (candidates, k, n)
    mean = table.mean(axis=1)
    if default is not None:
        own = table[labels.index(default)]
        beaten = np.all(table <= margin * own, axis=1)  # (candidates, n)
        beaten[labels.index(default)] = True
        mean = np.where(beaten, mean, np.inf)
    return [labels[k] for k in np.argmin(mean, axis=0)]


class JointChoice(SavedEstimator):
    """Each joint's effort from its own model.

    Parameters
    ----------
    models : mapping of str to Estimator
        The candidates, by label, each of the same joints (n outputs, 3n inputs).
    choice : sequence of str
        The label of each joint's model (n).

    Attributes
    ----------
    models : dict of str to Estimator
        The candidates some joint uses.
    choice : tuple of str
    metadata : dict of str to ndarray
    """

    kind = KIND

    def __init__(self, models: Mapping[str, Estimator], choice: Sequence[str]) -> None:
        missing = sorted(set(choice) - set(models))
        if missing or not choice:
            raise ValueError(f'a joint choice needs a model of every label chosen; '
                             f'missing {missing}')
        self.choice = tuple(choice)
        self.models = {label: models[label] for label in dict.fromkeys(self.choice)}
        sizes = {(m.n_inputs, m.n_outputs) for m in self.models.values()}
        if sizes != {(3 * len(self.choice), len(self.choice))}:
            raise ValueError(f'every model must map {3 * len(self.choice)} inputs to '
                             f'{len(self.choice)} efforts; got {sorted(sizes)}')
        first = next(iter(self.models.values()))
        names = first.joint_names
        self.metadata: dict[str, np.ndarray] = (
            {} if names is None else {'joint_names': np.array(names)})

    @property
    def n_inputs(self) -> int:
        """3n."""
        return 3 * len(self.choice)

    @property
    def n_outputs(self) -> int:
        """n."""
        return len(self.choice)

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joints recorded in :attr:`metadata`, else the first model's."""
        recorded = self.metadata.get('joint_names')
        if recorded is not None:
            return tuple(str(name) for name in np.atleast_1d(recorded))
        return next(iter(self.models.values())).joint_names

    @property
    def physical(self) -> PhysicalModel:
        """The physical model among the candidates (a hybrid's physical part if no physical
        model is one): what ``export --urdf`` writes.

        Raises
        ------
        TypeError
            If no candidate holds one.
        """
        for model in self.models.values():
            if isinstance(model, PhysicalModel):
                return model
        for model in self.models.values():
            if isinstance(model, HybridModel):
                return model.physical
        raise TypeError(f'no physical model among {", ".join(self.models)}')

    def get_params(self) -> dict[str, Any]:
        """Each candidate's hyperparameters, by label, and the choice."""
        return {'choice': self.choice,
                **{label: m.get_params() for label, m in self.models.items()}}

    def fit(self, X: ArrayLike, Y: ArrayLike) -> JointChoice:
        """Refit every candidate on X (N, 3n), Y (N, n), the choice kept (the candidates'
        own ``fit``)."""
        for model in self.models.values():
            model.fit(X, Y)
        return self

    def predict(self, X: ArrayLike) -> FloatArray:
        """Efforts of X (N, 3n) or (3n,): each joint from its model, (N, n) or (n,)."""
        x = np.asarray(X, dtype=np.float64)
        rows = np.atleast_2d(x)
        out = np.empty((rows.shape[0], self.n_outputs))
        for label, model in self.models.items():
            joints = [j for j, chosen in enumerate(self.choice) if chosen == label]
            out[:, joints] = np.asarray(model.predict(rows))[:, joints]
        return out[0] if x.ndim == 1 else out

    def partial_fit(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        """Not learnt online.

        Raises
        ------
        NotImplementedError
            Always: a choice is made offline (``scara-ident train``).
        """
        raise NotImplementedError('a JointChoice is chosen offline (scara-ident train)')

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Every kept candidate's entries prefixed by its label, with its kind; the labels
        and the choice (module docstring)."""
        arrays: dict[str, np.ndarray] = {'labels': np.array(list(self.models)),
                                         'choice': np.array(self.choice)}
        for label, model in self.models.items():
            arrays[f'{label}.kind'] = np.array(model.kind)
            arrays.update({f'{label}.{k}': v for k, v in
                           model.to_arrays().items()})  # type: ignore[attr-defined]
        return arrays

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], *, source: str) -> JointChoice:
        """Rebuild from :meth:`to_arrays`'s entries; ``source`` names them in errors.

        Raises
        ------
        ModelFormatError
            If they are not a joint choice of ours or are corrupt.
        """
        try:
            models = {}
            for label in (str(v) for v in np.atleast_1d(arrays['labels'])):
                kind = str(arrays[f'{label}.kind'])
                if kind not in _FROM_ARRAYS:
                    raise ValueError(f'candidate {label} of unknown kind {kind!r}')
                prefix = f'{label}.'
                entries = {k[len(prefix):]: v for k, v in arrays.items()
                           if k.startswith(prefix) and k != f'{label}.kind'}
                models[label] = _FROM_ARRAYS[kind](entries, source)
            return cls(models, [str(v) for v in np.atleast_1d(arrays['choice'])])
        except (KeyError, ValueError) as exc:
            raise ModelFormatError(f'{source}: corrupt joint choice: {exc}') from None


register_kind(KIND, JointChoice.load)
