"""Table 2 analog: offline (batch) training of FFMW, FFW, FFS with Levenberg–Marquardt.

Each method is trained from several seeds on the same samples for the paper's 315
iterations, then evaluated on the training samples (``'train'``) and on each of
``evaluations`` (name → (X (N, 3n), Y (N, n))). The *iterations to the goal* are read from
the training history (first iteration whose scaled MSE is <= ``goal``), so both of the
paper's figures come from one run. With ``scaling=None`` the network scales from the
training data's ranges (like MATLAB's ``mapminmax``), so the goal is relative to them.
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
from scara_ident_ros.nn.presets import HIDDEN_UNITS, METHODS, make_network
from scara_ident_ros.nn.presets import method as method_spec
from scara_ident_ros.nn import FeedForwardNet, FitHistory

__all__ = ['DEFAULT_GOAL', 'OfflineFit', 'OfflineRuns', 'fit_offline', 'goal_iteration',
           'offline_rows', 'run_offline', 'train_offline']

FloatArray = npt.NDArray[np.float64]

DEFAULT_GOAL = 1e-5  # training MSE of outputs scaled to [-1, 1]: about 0.3 % RMS of half-range


@dataclass(frozen=True)
class OfflineFit:
    """A network trained offline: ``seconds``, ``cpu_seconds`` are the wall and process CPU
    time of ``fit`` (s), ``history`` its scaled MSE per iteration."""

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
                n_hidden: int = HIDDEN_UNITS) -> OfflineFit:
    """Train one network of ``method`` with Levenberg–Marquardt for ``iterations``.

    Parameters
    ----------
    X : array_like of shape (N, 3n)
        Inputs [q, q', q''].
    Y : array_like of shape (N, n)
        Efforts (N·m, N).
    hyperparameters : Hyperparameters, optional
        Only ``weight_scale`` matters to LM; default the METHODS values.
    iterations : int
        Iteration limit; LM stops earlier only at its damping limit.
    scaling : (x_min, x_max, y_min, y_max), optional
        Physical ranges mapped to [-1, 1]; default the training data's.
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    hyper = hyperparameters or Hyperparameters.defaults(method)
    net = make_network(method, y.shape[1], seed=seed, n_hidden=n_hidden, **asdict(hyper))
    if scaling is not None:
        net.set_scaling(*scaling)
    wall, cpu = time.perf_counter(), time.process_time()
    net.fit(x, y, validation_fraction=0.0, samples=0, algorithm='lm', iterations=iterations,
            goal=0.0)  # the paper's protocol: every sample, no early stop
    assert net.history_ is not None
    return OfflineFit(method, seed, net, net.history_, time.perf_counter() - wall,
                      time.process_time() - cpu, int(x.shape[0]))


def goal_iteration(history: FitHistory, goal: float) -> int | None:
    """First iteration (0 = before training) whose training MSE was <= ``goal``, or None."""
    for i, mse in enumerate(history.mse):
        if mse <= goal:
            return i
    return None


def offline_rows(fit: OfflineFit, evaluations: Evaluations, *,
                 goal: float | None = None) -> list[ResultRow]:
    """Evaluate a trained network on each data set (name → (X, Y)): one row each; ``goal``
    (scaled MSE) fills the iterations-to-goal column."""
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
    """What `train_offline` produced: rows by method, seed and data set (``'train'``
    first), the fits per method key, the seeds done and those the time budget left out."""

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
    X, Y : array_like of shape (N, 3n), (N, n)
        Training inputs and efforts (N·m, N); ``iterations``, ``goal``, ``scaling`` as in
        `fit_offline`.
    hyperparameters : mapping of method key to Hyperparameters, optional
        Missing methods take the METHODS defaults.
    time_budget_s : float, optional
        No round starts that would end past it by the mean round time; the first always
        runs.
    progress : callable, optional
        Called with a one-line message after each training.
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
