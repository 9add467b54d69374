"""Per-method grid search of the online-learning hyperparameters, on training data only.

The searched values are those a user cannot take from the paper: the learning rate and
momentum of online back-propagation (``partial_fit``) and the spread of the initial weights
(``weight_scale``, see :class:`~scara_ident_ros.nn.FeedForwardNet`).

Procedure (`search`): for each point of the grid and each of a few weight seeds, a fresh
network with the robot-limit scaling learns the search segment sample by sample, a-priori
prediction first, exactly as the online identifier does. A run's error is the joint-mean NMSE
of those a-priori predictions over the last ``score_fraction`` of the segment: an honest
one-step-ahead error on samples not yet learnt, measured after the network has had the first
part of the segment to converge; a run whose step becomes non-finite has +inf. The point's
score is the *worst* of its seeds: large steps sit next to instability, where one seed can be
lucky and the next blow up, and the chosen values become the defaults of a live node. The
lowest score wins; ties go to the earlier grid point. No held-out data is used.

Public API::

    Hyperparameters(learning_rate, momentum, weight_scale)
    Hyperparameters.defaults(method) -> Hyperparameters      the METHODS values
    Grid(learning_rate=..., momentum=..., weight_scale=...)  .points() -> list, .size
    DEFAULT_GRID, QUICK_GRID
    build_network(method, n_joints, hyperparameters=None, *, seed=0, n_hidden=40)
        -> FeedForwardNet
    search(method, X, Y, *, scaling, grid=DEFAULT_GRID, seeds=(0, 1), score_fraction=0.5)
        -> SearchResult                                      .best, .trials
    best_of(results) -> dict[str, Hyperparameters]           method key -> choice
"""
from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from scara_ident_ros.methods import method as method_spec
from scara_ident_ros.nn import FeedForwardNet

__all__ = ['DEFAULT_GRID', 'QUICK_GRID', 'Grid', 'Hyperparameters', 'Scaling', 'SearchResult',
           'Trial', 'best_of', 'build_network', 'search']

FloatArray = npt.NDArray[np.float64]

#: Physical ranges (x_min (3n,), x_max (3n,), y_min (n,), y_max (n,)) mapped to [-1, 1], as
#: returned by :func:`scara_ident_ros.methods.limit_scaling`.
Scaling = tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, npt.ArrayLike]


@dataclass(frozen=True)
class Hyperparameters:
    """Online-learning settings of one network.

    Attributes
    ----------
    learning_rate : float
        Step size of ``partial_fit`` (scaled units).
    momentum : float
        Momentum of ``partial_fit``, in [0, 1).
    weight_scale : float
        Initial spread of the hidden units' net input.
    """

    learning_rate: float
    momentum: float
    weight_scale: float

    @classmethod
    def defaults(cls, method: str) -> Hyperparameters:
        """The defaults of ``method`` in :data:`scara_ident_ros.methods.METHODS`."""
        spec = method_spec(method)
        return cls(spec.learning_rate, spec.momentum, spec.weight_scale)

    def __str__(self) -> str:
        return (f'learning_rate={self.learning_rate:g}, momentum={self.momentum:g}, '
                f'weight_scale={self.weight_scale:g}')


@dataclass(frozen=True)
class Grid:
    """The values tried for each hyperparameter; the grid is their Cartesian product."""

    learning_rate: tuple[float, ...] = (0.03, 0.1, 0.3, 1.0)
    momentum: tuple[float, ...] = (0.0, 0.5, 0.9)
    weight_scale: tuple[float, ...] = (1.0, 2.0, 4.0)

    def points(self) -> list[Hyperparameters]:
        """All combinations, learning rate varying slowest."""
        return [Hyperparameters(lr, m, w) for lr, m, w
                in itertools.product(self.learning_rate, self.momentum, self.weight_scale)]

    @property
    def size(self) -> int:
        """Number of grid points."""
        return len(self.learning_rate) * len(self.momentum) * len(self.weight_scale)


#: The grid of ``scara-ident compare``: 36 points per method. In a first, single-seed search
#: on the default training stream with learning rates 0.01–0.3, 0.01 was the worst rate for
#: every method (best score at 0.01: 1.4e-3 FFMW, 4.6e-3 FFW, 1.4e-3 FFS; best overall:
#: 5.1e-5, 1.1e-4, 5.4e-5) and two methods chose 0.3, the top: the range now runs from 0.03
#: to 1.0, past the largest stable step.
DEFAULT_GRID = Grid()
#: A 2-point grid for ``--quick`` runs and tests.
QUICK_GRID = Grid(learning_rate=(0.03, 0.1), momentum=(0.9,), weight_scale=(2.0,))


@dataclass(frozen=True)
class Trial:
    """One grid point's result.

    Attributes
    ----------
    hyperparameters : Hyperparameters
    score : float
        The worst of ``scores``.
    scores : tuple of float
        Per seed: joint-mean NMSE of the a-priori predictions over the scored part; +inf if
        diverged.
    diverged : bool
        A step became non-finite for some seed.
    seconds : float
        Wall time of the trial, all seeds (s).
    """

    hyperparameters: Hyperparameters
    score: float
    scores: tuple[float, ...]
    diverged: bool
    seconds: float


@dataclass(frozen=True)
class SearchResult:
    """The outcome of `search` for one method.

    Attributes
    ----------
    method : str
        Method key (``'ffmw'``).
    trials : tuple of Trial
        In grid order.
    best : Hyperparameters
        The lowest-scoring point; the METHODS defaults if every point diverged.
    n_samples : int
        Samples in the search segment.
    n_scored : int
        Samples the score covers (the segment's last ones).
    seeds : tuple of int
        Seeds of the networks' initial weights.
    """

    method: str
    trials: tuple[Trial, ...]
    best: Hyperparameters
    n_samples: int
    n_scored: int
    seeds: tuple[int, ...]

    @property
    def best_trial(self) -> Trial | None:
        """The trial of `best`, or None if every point diverged."""
        finite = [t for t in self.trials if math.isfinite(t.score)]
        return min(finite, key=lambda t: t.score) if finite else None


def build_network(method: str, n_joints: int, hyperparameters: Hyperparameters | None = None,
                  *, seed: int = 0, n_hidden: int = 40) -> FeedForwardNet:
    """The (3n)-n_hidden-n network of ``method`` with the given hyperparameters.

    Like :func:`scara_ident_ros.methods.make_network`, which takes no ``weight_scale``;
    None takes the method's defaults. The scaling is left unset.
    """
    spec = method_spec(method)
    hyper = Hyperparameters.defaults(method) if hyperparameters is None else hyperparameters
    return FeedForwardNet(3 * n_joints, n_hidden, n_joints, spec.activation, seed=seed,
                          weight_scale=hyper.weight_scale, learning_rate=hyper.learning_rate,
                          momentum=hyper.momentum)


def _run_error(method: str, hyper: Hyperparameters, X: FloatArray, Y: FloatArray,
               scaling: Scaling, seed: int, n_scored: int) -> float:
    """Joint-mean NMSE of one run's a-priori errors over the last n_scored samples."""
    net = build_network(method, Y.shape[1], hyper, seed=seed)
    net.set_scaling(*scaling)
    n_fit = X.shape[0] - n_scored
    try:
        with np.errstate(over='ignore', invalid='ignore'):
            net.partial_fit(X[:n_fit], Y[:n_fit])
            errors = net.partial_fit(X[n_fit:], Y[n_fit:])
    except ValueError:
        return math.inf
    var = Y[n_fit:].var(axis=0)
    nmse = np.mean(errors ** 2, axis=0) / np.where(var > 0.0, var, np.nan)
    score = float(np.nanmean(nmse))
    return score if math.isfinite(score) else math.inf


def _trial(method: str, hyper: Hyperparameters, X: FloatArray, Y: FloatArray,
           scaling: Scaling, seeds: Sequence[int], n_scored: int) -> Trial:
    start = time.perf_counter()
    scores = tuple(_run_error(method, hyper, X, Y, scaling, seed, n_scored) for seed in seeds)
    return Trial(hyper, max(scores), tuple(scores), any(math.isinf(s) for s in scores),
                 time.perf_counter() - start)


def search(method: str, X: npt.ArrayLike, Y: npt.ArrayLike, *, scaling: Scaling,
           grid: Grid = DEFAULT_GRID, seeds: Sequence[int] = (0, 1),
           score_fraction: float = 0.5) -> SearchResult:
    """Choose ``method``'s hyperparameters on a training segment (module docstring).

    Parameters
    ----------
    method : str
        Method key (``'ffmw'``, ``'ffw'``, ``'ffs'``).
    X : array_like of shape (N, 3n)
        Inputs [q, q', q''] of the search segment, in time order (q'' as online: estimated).
    Y : array_like of shape (N, n)
        Efforts (N·m, N).
    scaling : (x_min, x_max, y_min, y_max)
        Physical ranges of the networks' scaling (the robot limits, as online).
    grid : Grid
        Values to try.
    seeds : sequence of int
        Seeds of the initial weights tried at every grid point; the worst counts.
    score_fraction : float
        Fraction in (0, 1) of the segment, at its end, that the score covers.

    Returns
    -------
    SearchResult
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    if not 0.0 < score_fraction < 1.0:
        raise ValueError(f'score_fraction must be in (0, 1), got {score_fraction}')
    n_scored = int(round(score_fraction * x.shape[0]))
    if n_scored < 2 or n_scored >= x.shape[0]:
        raise ValueError(f'search segment of {x.shape[0]} samples is too short')
    seeds = tuple(int(s) for s in seeds)
    if not seeds:
        raise ValueError('need at least one seed')
    trials = tuple(_trial(method, h, x, y, scaling, seeds, n_scored) for h in grid.points())
    finite = [t for t in trials if math.isfinite(t.score)]
    best = (min(finite, key=lambda t: t.score).hyperparameters if finite
            else Hyperparameters.defaults(method))
    return SearchResult(method=method, trials=trials, best=best, n_samples=int(x.shape[0]),
                        n_scored=n_scored, seeds=seeds)


def best_of(results: Sequence[SearchResult]) -> dict[str, Hyperparameters]:
    """Map each result's method to its chosen hyperparameters."""
    return {r.method: r.best for r in results}
