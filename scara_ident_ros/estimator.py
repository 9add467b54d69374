"""The estimator contract every effort model keeps, and the one loader of model files.

Every model of the package (network, physical, hybrid, kernel, ...) maps inputs to joint
efforts with the scikit-learn estimator calls, so that a user with arrays writes::

    model = KernelModel(n_features=1000)      # hyperparameters as constructor data
    model.fit(X, Y)                            # X (N, 3n) = [q, q', q''], Y (N, n)
    model.score(Xt, Yt)                        # 1 - mean NMSE over the joints (R²)
    model.save('wam.npz')
    same = load_model('wam.npz')               # the kind is read from the file

and the CLI, the node and the paper's code make the same calls. Shapes and units::

    X : (N, 3n) float64   [q_1..q_n, q'_1..q'_n, q''_1..q''_n] (rad, m, /s, /s²)
    Y : (N, n) float64    joint efforts (N·m, N)

A model that learns online also has ``partial_fit(X, Y)``, which returns its predictions of
the samples *before* it learns them (each sample predicted before it is learnt).

Model files are ``.npz`` archives with a ``kind`` (:mod:`scara_ident_ros.nn.model_file`);
:func:`load_model` finds the class registered for that kind with :func:`register_kind`.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, TypeVar, runtime_checkable

import numpy as np
import numpy.typing as npt

__all__ = ['Estimator', 'OnlineEstimator', 'SavedEstimator', 'check_samples', 'load_model',
           'r2_score', 'register_kind', 'registered_kinds']

FloatArray = npt.NDArray[np.float64]
_S = TypeVar('_S', bound='SavedEstimator')


@runtime_checkable
class Estimator(Protocol):
    """What every effort model offers (module docstring for shapes and units)."""

    #: The model file's kind, read back by :func:`load_model`.
    kind: str
    #: Saved with the model (numbers, booleans, strings): ``joint_names``, ``method``, ...
    metadata: dict[str, np.ndarray]

    @property
    def n_inputs(self) -> int:
        """3n: the columns of X."""

    @property
    def n_outputs(self) -> int:
        """n: the columns of Y."""

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joints of Y's columns, in order, or None if not recorded."""

    @property
    def method(self) -> str:
        """The method key the model was made by (``'ffs'``, ``'physical'``, ...)."""

    def fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> Any:
        """Learn from samples X (N, 3n) and efforts Y (N, n); returns the model."""

    def predict(self, X: npt.ArrayLike) -> FloatArray:
        """Efforts (N, n) for inputs X (N, 3n)."""

    def score(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> float:
        """1 − mean over the joints of NMSE (R², higher is better): :func:`r2_score`."""

    def get_params(self) -> dict[str, Any]:
        """The hyperparameters given to the constructor, as data."""

    def save(self, path: str | Path) -> None:
        """Write the model to ``path`` (an .npz model file holding its kind)."""


@runtime_checkable
class OnlineEstimator(Estimator, Protocol):
    """An estimator that learns sample by sample (or batch by batch) on a stream."""

    def partial_fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> FloatArray:
        """Predict Y (N, n) from X (N, 3n), then learn the samples; returns the predictions
        made before learning."""


class SavedEstimator:
    """What a model file's learner shares: its kind, :attr:`metadata`, its sizes, the score,
    the file round trip and the names recorded in the metadata.

    A subclass sets :attr:`kind` and writes ``to_arrays()`` and the classmethod
    ``from_arrays(arrays, *, source)``; :meth:`save` and :meth:`load` go through
    :func:`~scara_ident_ros.nn.model_file.write_model` and ``read_model_file(kind=...)``.
    """

    kind: str = ''
    metadata: dict[str, np.ndarray]

    def to_arrays(self) -> dict[str, np.ndarray]:  # pragma: no cover - each model's own
        raise NotImplementedError

    @classmethod
    def from_arrays(cls: type[_S], arrays: dict[str, np.ndarray], *,
                    source: str) -> _S:  # pragma: no cover - each model's own
        raise NotImplementedError

    def predict(self, X: npt.ArrayLike) -> FloatArray:  # pragma: no cover - each model's own
        raise NotImplementedError

    def score(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> float:
        """1 − mean NMSE over the joints (:func:`r2_score`)."""
        return r2_score(Y, self.predict(X))

    def save(self, path: str | Path) -> None:
        """Write the model (its :attr:`kind`) with its :attr:`metadata`, atomically."""
        from scara_ident_ros.nn.model_file import write_model

        write_model(path, self.to_arrays(), self.metadata, kind=self.kind)

    @classmethod
    def load(cls: type[_S], path: str | Path) -> _S:
        """Read a model written by :meth:`save`.

        Raises
        ------
        scara_ident_ros.nn.ModelFormatError
            If the file is not a model of this kind or is corrupt.
        """
        from scara_ident_ros.nn.model_file import read_model_file

        file = read_model_file(path, kind=cls.kind)
        model = cls.from_arrays(file.arrays, source=str(path))
        model.metadata = file.metadata
        return model

    n_inputs_: int
    n_outputs_: int

    def _need_ready(self) -> None:  # pragma: no cover - each model's own
        """Raise if the model has seen no data yet (its sizes are unknown)."""
        raise NotImplementedError

    @property
    def n_inputs(self) -> int:
        """Number of inputs d = 3n (after the first data)."""
        self._need_ready()
        return self.n_inputs_

    @property
    def n_outputs(self) -> int:
        """Number of joints n (after the first data)."""
        self._need_ready()
        return self.n_outputs_

    @property
    def method(self) -> str:
        """The method key: ``metadata['method']`` if recorded, else the kind."""
        method = self.metadata.get('method')
        return self.kind if method is None else str(method)

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joints in output order, if recorded in :attr:`metadata`."""
        names = self.metadata.get('joint_names')
        return None if names is None else tuple(str(s) for s in np.atleast_1d(names))


def check_samples(X: npt.ArrayLike, Y: npt.ArrayLike, shape: tuple[int, int] | None = None
                  ) -> tuple[FloatArray, FloatArray]:
    """X (N, d) and Y (N, n) as float64 arrays (Y of shape (N,) as (N, 1)), checked.

    Parameters
    ----------
    X, Y : array_like
        Inputs and efforts, N >= 1 rows each.
    shape : (int, int), optional
        The (d, n) a model already maps; None for its first data.

    Raises
    ------
    ValueError
        For other shapes, or values that are not finite.
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    if y.ndim == 1:
        y = y[:, None]
    if x.ndim != 2 or y.ndim != 2 or x.shape[0] != y.shape[0] or x.shape[0] < 1:
        raise ValueError(f'need X (N, d) and Y (N, n) with N >= 1; got {x.shape} '
                         f'and {y.shape}')
    if shape is not None and (x.shape[1], y.shape[1]) != shape:
        raise ValueError(f'the model maps {shape[0]} inputs to {shape[1]} outputs; '
                         f'got X {x.shape} and Y {y.shape}')
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError('X and Y must be finite')
    return x, y


def r2_score(Y: npt.ArrayLike, prediction: npt.ArrayLike) -> float:
    """1 − mean over the joints of MSE / variance of Y (joints with zero variance left out).

    Parameters
    ----------
    Y, prediction : array_like of shape (N, n)
        Measured and predicted efforts.
    """
    y = np.asarray(Y, dtype=np.float64)
    p = np.asarray(prediction, dtype=np.float64)
    if y.ndim == 1:
        y, p = y[:, None], p.reshape(-1, 1)
    if y.shape != p.shape or y.shape[0] < 2:
        raise ValueError(f'need Y and prediction of one shape (N >= 2, n); '
                         f'got {y.shape} and {p.shape}')
    var = y.var(axis=0)
    used = var > 0
    if not used.any():
        raise ValueError('every joint of Y is constant: R² is undefined')
    nmse = ((y - p) ** 2).mean(axis=0)[used] / var[used]
    return float(1.0 - nmse.mean())


_Loader = Callable[[Path], Estimator]
_LOADERS: dict[str, _Loader] = {}


def register_kind(kind: str, loader: _Loader) -> None:
    """Make :func:`load_model` read files of ``kind`` with ``loader(path)``."""
    _LOADERS[kind] = loader


def registered_kinds() -> tuple[str, ...]:
    """The kinds :func:`load_model` reads (after their modules are imported)."""
    _import_models()
    return tuple(sorted(_LOADERS))


def load_model(path: str | Path) -> Estimator:
    """Read a model file of any kind; the class comes from the kind stored in the file.

    Raises
    ------
    scara_ident_ros.nn.ModelFormatError
        If the file is not a model file of ours or holds a kind no class reads.
    """
    from scara_ident_ros.nn.model_file import read_model_file
    from scara_ident_ros.nn.errors import ModelFormatError

    path = Path(path)
    kind = read_model_file(path).kind
    _import_models()
    loader = _LOADERS.get(kind)
    if loader is None:
        raise ModelFormatError(f'{path}: a {kind!r} model, which no model class reads '
                               f'(known: {", ".join(sorted(_LOADERS))})')
    return loader(path)


def _import_models() -> None:
    """Import the model modules, each registering its kind (lazily: Pinocchio is heavy)."""
    import importlib

    for module in _MODEL_MODULES:
        importlib.import_module(module)


#: Modules that call :func:`register_kind` when imported.
_MODEL_MODULES: list[str] = ['scara_ident_ros.nn.network',
                             'scara_ident_ros.dynamics.physical_model',
                             'scara_ident_ros.learners.hybrid_model',
                             'scara_ident_ros.learners.sparse_spectrum_gp',
                             'scara_ident_ros.learners.exact_gp',
                             'scara_ident_ros.learners.linear_features',
                             'scara_ident_ros.learners.joint_choice']
