"""Table 2 analog: offline (batch) training of FFMW, FFW, FFS with Levenberg–Marquardt.

Each method is trained from several seeds of its initial weights on the same training
samples for a fixed number of iterations (the paper's 315), then evaluated on the training
samples and on any other data sets (e.g. a held-out run on another excitation). Training
always runs to the iteration limit; the *iterations to the goal* are read afterwards from the
training history: the first iteration whose training MSE, in the network's scaled units
(outputs mapped to [-1, 1]), is <= ``goal``. Thus both the paper's figures, the MSE after 315
iterations and how fast the goal is reached, come from one run.

Scaling: with ``scaling=None`` each network maps inputs and outputs to [-1, 1] from the
training data's minima and maxima (``nn.fit``'s default, like MATLAB's
``mapminmax``), so the goal is relative to the training data's ranges.

Public API (plain arrays; X (N, 3n) = [q, q', q''], Y (N, n) efforts)::

    OfflineFit                                  network, history, seconds, cpu_seconds
    fit_offline(method, X, Y, *, seed=0, hyperparameters=None, iterations=315,
                scaling=None, n_hidden=40) -> OfflineFit
    goal_iteration(history, goal) -> int | None
    offline_rows(fit, evaluations, *, goal=None) -> list[ResultRow]
    train_offline(X, Y, evaluations=None, *, methods=('ffmw', 'ffw', 'ffs'), seeds=range(5),
                  iterations=315, goal=1e-5, hyperparameters=None, scaling=None,
                  time_budget_s=None, progress=None) -> OfflineRuns
    run_offline(X, Y, evaluations=None, **options) -> list[ResultRow]  (train_offline's rows)

``evaluations`` maps a data name to (X, Y), e.g. ``{'held-out': (X_test, Y_test)}``;
`train_offline` always adds ``'train'`` (the fitted samples) first.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from scara_ident_ros.paper.datasets import Evaluations
from scara_ident_ros.paper.hyperparameters import Hyperparameters, Scaling
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.paper.rows import ResultRow
from scara_ident_ros.paper.tables import PAPER_ITERATIONS
from scara_ident_ros.nn.presets import METHODS, make_network
from scara_ident_ros.nn.presets import method as method_spec
from scara_ident_ros import nn
from scara_ident_ros.nn import FeedForwardNet, FitHistory

__all__ = ['DEFAULT_GOAL', 'OfflineFit', 'OfflineRuns', 'fit_offline', 'goal_iteration',
           'offline_rows', 'run_offline', 'train_offline']

FloatArray = npt.NDArray[np.float64]

DEFAULT_GOAL = 1e-5  # training MSE of outputs scaled to [-1, 1]: about 0.3 % RMS of half-range


@dataclass(frozen=True)
class OfflineFit:
    """A network trained offline.

    Attributes
    ----------
    method : str
        Method key (``'ffmw'``).
    seed : int
        Seed of the initial weights.
    network : FeedForwardNet
        The trained network.
    history : FitHistory
        Its training history (scaled MSE per iteration).
    seconds, cpu_seconds : float
        Wall and process CPU time of ``fit`` (s).
    n_samples : int
        Training samples.
    """

    method: str
    seed: int
    network: FeedForwardNet
    history: FitHistory
    seconds: float
    cpu_seconds: float
    n_samples: int


def fit_offline(method: str, X: npt.ArrayLike, Y: npt.ArrayLike, *, seed: int = 0,
                hyperparameters: Hyperparameters | None = None,
                iterations: int = PAPER_ITERATIONS, scaling: Scaling | None = None,
                n_hidden: int = 40) -> OfflineFit:
    """Train one network of ``method`` with Levenberg–Marquardt for ``iterations``.

    Parameters
    ----------
    method : str
        Method key.
    X : array_like of shape (N, 3n)
        Inputs [q, q', q''].
    Y : array_like of shape (N, n)
        Efforts (N·m, N).
    seed : int
        Seed of the initial weights.
    hyperparameters : Hyperparameters, optional
        Only ``weight_scale`` matters to LM; default the METHODS values.
    iterations : int
        Iteration limit; training stops earlier only if LM cannot go on (damping limit).
    scaling : (x_min, x_max, y_min, y_max), optional
        Physical ranges mapped to [-1, 1]; default the training data's minima and maxima.
    n_hidden : int
        Hidden units.
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    hyper = hyperparameters or Hyperparameters.defaults(method)
    net = make_network(method, y.shape[1], seed=seed, n_hidden=n_hidden, **asdict(hyper))
    if scaling is not None:
        net.set_scaling(*scaling)
    wall, cpu = time.perf_counter(), time.process_time()
    history = nn.fit(net, x, y, algorithm='lm', iterations=iterations, goal=0.0)
    return OfflineFit(method, seed, net, history, time.perf_counter() - wall,
                      time.process_time() - cpu, int(x.shape[0]))


def goal_iteration(history: FitHistory, goal: float) -> int | None:
    """First iteration (0 = before training) whose training MSE was <= ``goal``, or None."""
    for i, mse in enumerate(history.mse):
        if mse <= goal:
            return i
    return None


def offline_rows(fit: OfflineFit, evaluations: Evaluations, *,
                 goal: float | None = None) -> list[ResultRow]:
    """Evaluate a trained network on each data set: one row per data set.

    Parameters
    ----------
    fit : OfflineFit
    evaluations : mapping of str to (X (N, 3n), Y (N, n))
    goal : float, optional
        Training goal (scaled MSE) for the iterations-to-goal column.
    """
    label = method_spec(fit.method).label
    history = fit.history
    reached = None if goal is None else goal_iteration(history, goal)
    diverged = history.stop_reason == 'diverged'
    note = '' if history.stop_reason == 'iterations' else f'stopped: {history.stop_reason}'
    rows = []
    for data, (x, y) in evaluations.items():
        stats = effort_errors(y, fit.network.predict(np.asarray(x, dtype=np.float64)))
        rows.append(ResultRow.from_stats(
            stats, table='offline', method=label, seed=fit.seed, data=data,
            iterations=history.iterations, goal=goal, goal_iteration=reached,
            train_time_s=fit.seconds, cpu_time_s=fit.cpu_seconds, diverged=diverged,
            note=note))
    return rows


@dataclass(frozen=True)
class OfflineRuns:
    """What `train_offline` produced.

    Attributes
    ----------
    rows : list of ResultRow
        Method by method, seed by seed, data set by data set (``'train'`` first).
    fits : dict of str to list of OfflineFit
        Method key to its trained networks, one per seed done.
    seeds, seeds_skipped : list of int
        Seeds done for every method; seeds left out by the time budget.
    """

    rows: list[ResultRow]
    fits: dict[str, list[OfflineFit]]
    seeds: list[int]
    seeds_skipped: list[int]


def train_offline(X: npt.ArrayLike, Y: npt.ArrayLike, evaluations: Evaluations | None = None,
                  *, methods: Sequence[str] = tuple(METHODS), seeds: Iterable[int] = range(5),
                  iterations: int = PAPER_ITERATIONS, goal: float = DEFAULT_GOAL,
                  hyperparameters: Mapping[str, Hyperparameters] | None = None,
                  scaling: Scaling | None = None, time_budget_s: float | None = None,
                  progress: Callable[[str], None] | None = None) -> OfflineRuns:
    """Train every method from every seed and evaluate: the Table 2 analog.

    Seeds run in rounds (seed 0 for every method, then seed 1, ...), so that a time budget
    stops between rounds and every method has the same seeds.

    Parameters
    ----------
    X : array_like of shape (N, 3n)
        Training inputs.
    Y : array_like of shape (N, n)
        Training efforts.
    evaluations : mapping of str to (X, Y), optional
        Further data sets, evaluated after ``'train'``.
    methods : sequence of str
        Method keys.
    seeds : iterable of int
        Seeds of the initial weights.
    iterations, goal, scaling
        See `fit_offline` and the module docstring.
    hyperparameters : mapping of method key to Hyperparameters, optional
        Missing methods take the METHODS defaults.
    time_budget_s : float, optional
        Wall time after which no new round of seeds starts: a round is skipped when the
        time so far plus the mean time of the rounds done would exceed it. The first round
        always runs.
    progress : callable, optional
        Called with a one-line message after each training.

    Returns
    -------
    OfflineRuns
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    data: dict[str, tuple[npt.ArrayLike, npt.ArrayLike]] = {'train': (x, y), **(evaluations or {})}
    seeds = list(seeds)
    say = progress or (lambda line: None)
    started = time.perf_counter()
    rows: dict[str, list[ResultRow]] = {m: [] for m in methods}
    fits: dict[str, list[OfflineFit]] = {m: [] for m in methods}
    for k, seed in enumerate(seeds):
        elapsed = time.perf_counter() - started
        if time_budget_s is not None and k > 0 and elapsed * (k + 1) / k > time_budget_s:
            say(f'time budget of {time_budget_s:g} s for offline training: seeds '
                f'{", ".join(map(str, seeds[k:]))} left out after {elapsed:.1f} s')
            return OfflineRuns(sum(rows.values(), []), fits, seeds[:k], seeds[k:])
        for m in methods:
            fit = fit_offline(m, x, y, seed=seed, hyperparameters=(hyperparameters or {}).get(m),
                              iterations=iterations, scaling=scaling)
            fits[m].append(fit)
            new = offline_rows(fit, data, goal=goal)
            rows[m].extend(new)
            say(f'offline {new[0].method} seed {seed}: {fit.history.iterations} LM iterations '
                f'in {fit.seconds:.1f} s, training MSE (scaled) {fit.history.final_mse:.3g}; '
                'NMSE ' + ', '.join(f'{row.data} {row.nmse_mean:.3g}' for row in new))
    return OfflineRuns(sum(rows.values(), []), fits, seeds, [])


def run_offline(X: npt.ArrayLike, Y: npt.ArrayLike, evaluations: Evaluations | None = None,
                **options: Any) -> list[ResultRow]:
    """The rows of `train_offline` (same arguments): method, seed, data set."""
    return train_offline(X, Y, evaluations, **options).rows
