"""Per-method grid search of the online-learning hyperparameters, on training data only.

The searched values are those a user cannot take from the paper: the learning rate and
momentum of online back-propagation (``partial_fit``) and the spread of the initial weights
(``weight_scale``, see :class:`~scara_ident_ros.nn.FeedForwardNet`).

Procedure (`search`). For each grid point and each of a few weight seeds, a fresh network
with the robot-limit scaling goes through the search segment as the online identifier does:
it learns the first part sample by sample; at the split it is copied and the copy, frozen,
predicts the rest (the *frozen* error); the network itself goes on predicting each remaining
sample before learning it (the *a-priori* error). Each error is the joint-mean NMSE over the
rest of the segment; a run whose step becomes non-finite has +inf.

* Score: the a-priori error, worst of the seeds: what the online identifier reports; the
  worst seed counts because large steps sit next to instability.
* Stability margin: the values become a live node's defaults, so a point is eligible only
  if, for every seed, it and the next larger learning rate (same momentum and weight scale)
  beat the mean (a-priori NMSE < 1); the largest rate is never eligible. The lowest eligible
  score wins (ties: the earlier point), else the lowest finite score.
* The frozen error is reported, not used to choose: per-sample learning follows the latest
  samples, so no point's frozen network beats the mean (docs/results.md).

No held-out data is used.
"""
from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt

from scara_ident_ros.identification.metrics import normalised_mse
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn.presets import method as method_spec

__all__ = ['DEFAULT_GRID', 'QUICK_GRID', 'Grid', 'Hyperparameters', 'Scaling', 'SearchResult',
           'Trial', 'best_of', 'search']

FloatArray = npt.NDArray[np.float64]

#: Physical ranges (x_min (3n,), x_max (3n,), y_min (n,), y_max (n,)) mapped to [-1, 1], as
#: returned by :func:`scara_ident_ros.nn.presets.limit_scaling`.
Scaling = tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, npt.ArrayLike]


@dataclass(frozen=True)
class Hyperparameters:
    """Online-learning settings of one network.

    Attributes
    ----------
    learning_rate, momentum : float
        Step size (scaled units) and momentum in [0, 1) of ``partial_fit``.
    weight_scale : float
        Initial spread of the hidden units' net input.
    """

    learning_rate: float
    momentum: float
    weight_scale: float

    @classmethod
    def defaults(cls, method: str) -> Hyperparameters:
        """The defaults of ``method`` in :data:`scara_ident_ros.nn.presets.METHODS`."""
        spec = method_spec(method)
        return cls(spec.learning_rate, spec.momentum, spec.weight_scale)

    def __str__(self) -> str:
        return (f'learning_rate={self.learning_rate:g}, momentum={self.momentum:g}, '
                f'weight_scale={self.weight_scale:g}')


@dataclass(frozen=True)
class Grid:
    """The values tried for each hyperparameter; the grid is their Cartesian product."""

    learning_rate: tuple[float, ...] = (0.03, 0.1, 0.3, 1.0, 3.0)
    momentum: tuple[float, ...] = (0.0, 0.5, 0.9)
    weight_scale: tuple[float, ...] = (1.0, 4.0)

    def points(self) -> list[Hyperparameters]:
        """All combinations, learning rate varying slowest."""
        return [Hyperparameters(lr, m, w) for lr, m, w
                in itertools.product(self.learning_rate, self.momentum, self.weight_scale)]

    @property
    def size(self) -> int:
        """Number of grid points."""
        return len(self.learning_rate) * len(self.momentum) * len(self.weight_scale)


#: The grid of ``scara-ident compare``, 30 points per method: rates wide enough that every
#: method diverges or fails for some setting (how they were set: docs/results.md).
DEFAULT_GRID = Grid()
#: A 3-point grid for ``--quick`` runs and tests.
QUICK_GRID = Grid(learning_rate=(0.03, 0.1, 0.3), momentum=(0.5,), weight_scale=(2.0,))


@dataclass(frozen=True)
class Trial:
    """One grid point's result.

    Attributes
    ----------
    score, scores : float, tuple of float
        Worst and per-seed joint-mean a-priori NMSE of the scored samples (+inf: diverged).
    frozen, frozen_scores : float, tuple of float
        The same for the network frozen at the split.
    eligible : bool
        Passes the stability margin (module docstring).
    seconds : float
        Wall time of the trial, all seeds (s).
    """

    hyperparameters: Hyperparameters
    score: float
    scores: tuple[float, ...]
    frozen: float
    frozen_scores: tuple[float, ...]
    eligible: bool
    seconds: float

    @property
    def diverged(self) -> bool:
        """A step became non-finite for some seed."""
        return any(math.isinf(v) for v in self.scores)


@dataclass(frozen=True)
class SearchResult:
    """The outcome of `search` for one method.

    Attributes
    ----------
    trials : tuple of Trial
        In grid order.
    best : Hyperparameters
        The chosen point; the METHODS defaults if every point diverged.
    n_samples, n_scored : int
        Samples in the search segment, and at its end in the score.
    seeds : tuple of int
        Seeds of the initial weights.
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
        return next((t for t in self.trials if t.hyperparameters == self.best
                     and math.isfinite(t.score)), None)


def _nmse(errors: FloatArray, y: FloatArray) -> float:
    """Joint-mean NMSE of a-priori ``errors`` of ``y``; +inf if not finite (diverged)."""
    var = y.var(axis=0)
    value = float(normalised_mse(np.mean(errors ** 2, axis=0), var, var)[1])
    return value if math.isfinite(value) else math.inf


def _run(method: str, hyper: Hyperparameters, X: FloatArray, Y: FloatArray,
         scaling: Scaling, seed: int, n_scored: int) -> tuple[float, float]:
    """(a-priori, frozen) joint-mean NMSE of one run over the last n_scored samples."""
    net = make_network(method, Y.shape[1], seed=seed, **asdict(hyper))
    net.set_scaling(*scaling)
    n_fit = X.shape[0] - n_scored
    with np.errstate(over='ignore', invalid='ignore'):
        try:
            net.partial_fit(X[:n_fit], Y[:n_fit])
        except ValueError:
            return math.inf, math.inf
        frozen = _nmse(Y[n_fit:] - net.predict(X[n_fit:]), Y[n_fit:])
        try:
            errors = net.partial_fit(X[n_fit:], Y[n_fit:])
        except ValueError:
            return math.inf, frozen
    return _nmse(errors, Y[n_fit:]), frozen


def _unstable(trial: Trial) -> bool:
    return any(not v < 1.0 for v in trial.scores)


def _with_margin(trials: list[Trial], grid: Grid) -> list[Trial]:
    """Mark each trial eligible if the next larger learning rate of the grid is stable."""
    by_point = {t.hyperparameters: t for t in trials}
    rates = sorted(grid.learning_rate)
    out = []
    for t in trials:
        h = t.hyperparameters
        i = rates.index(h.learning_rate)
        above = (by_point.get(Hyperparameters(rates[i + 1], h.momentum, h.weight_scale))
                 if i + 1 < len(rates) else None)
        eligible = above is not None and not _unstable(above) and not _unstable(t)
        out.append(Trial(h, t.score, t.scores, t.frozen, t.frozen_scores, eligible,
                         t.seconds))
    return out


def _trial(method: str, hyper: Hyperparameters, X: FloatArray, Y: FloatArray,
           scaling: Scaling, seeds: Sequence[int], n_scored: int) -> Trial:
    start = time.perf_counter()
    runs = [_run(method, hyper, X, Y, scaling, seed, n_scored) for seed in seeds]
    scores = tuple(r[0] for r in runs)
    frozen = tuple(r[1] for r in runs)
    return Trial(hyper, max(scores), scores, max(frozen), frozen, False,
                 time.perf_counter() - start)


def search(method: str, X: npt.ArrayLike, Y: npt.ArrayLike, *, scaling: Scaling,
           grid: Grid = DEFAULT_GRID, seeds: Sequence[int] = (0, 1),
           score_fraction: float = 0.5) -> SearchResult:
    """Choose ``method``'s hyperparameters on a training segment (module docstring).

    Parameters
    ----------
    X : array_like of shape (N, 3n)
        Inputs [q, q', q''] of the search segment, in time order (q'' as online: estimated);
        the first part is learnt, the last ``score_fraction`` predicted.
    Y : array_like of shape (N, n)
        Efforts (N·m, N).
    scaling : (x_min, x_max, y_min, y_max)
        Physical ranges of the networks' scaling (the robot limits, as online).
    seeds : sequence of int
        Seeds of the initial weights tried at every grid point; the worst counts.
    score_fraction : float
        Fraction in (0, 1) of the segment, at its end, that the score covers.
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
    trials = tuple(_with_margin([_trial(method, h, x, y, scaling, seeds, n_scored)
                                 for h in grid.points()], grid))
    candidates = ([t for t in trials if t.eligible]
                  or [t for t in trials if math.isfinite(t.score)])
    best = (min(candidates, key=lambda t: t.score).hyperparameters if candidates
            else Hyperparameters.defaults(method))
    return SearchResult(method=method, trials=trials, best=best, n_samples=int(x.shape[0]),
                        n_scored=n_scored, seeds=seeds)


def best_of(results: Sequence[SearchResult]) -> dict[str, Hyperparameters]:
    """Map each result's method to its chosen hyperparameters."""
    return {r.method: r.best for r in results}
