"""The Table 2 analog from a recorded run: each method retrained offline from several seeds.

The run's samples (made as the identifier makes them) come split as ``scara-ident train``
splits them (:func:`~scara_ident_ros.identification.split.block_split`): a fraction of its
time blocks, spread over the run, validate; the other blocks are the training part, of which
``samples`` random samples (the same for every method and seed) train each method's network
with Levenberg–Marquardt for ``iterations`` iterations
(:func:`scara_ident_ros.paper.table2.train_offline`, scaling from the training samples);
the validation blocks (never trained on) and any held-out runs are evaluated. With
``reference=True`` (the caller knows the run is the SCARA's, e.g.
:func:`scara_ident_ros.paper.reference.is_scara`) the SCARA's model-based least-squares
reference (LS) is added.

Seeds are run in rounds, so that a time budget can stop between rounds and every method
still has the same seeds. Training holds the BLAS
to one thread (:mod:`~scara_ident_ros.blas_threads`).
"""
from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.paper.table2 import OfflineFit, train_offline
from scara_ident_ros.paper.rows import ResultRow
from scara_ident_ros.blas_threads import single_blas_thread

__all__ = ['Retraining', 'retrain']


@dataclass(frozen=True)
class Retraining:
    """What offline retraining produced.

    Attributes
    ----------
    rows : list of ResultRow
        Table ``'offline'``: per method, seed and data set; then the LS reference, if any.
    fits : dict of str to list of OfflineFit
        Method key to its trained networks and histories, one per seed.
    evaluations : dict of str to Dataset
        ``'train'`` (the samples trained on), ``'validation'`` (the run's validation blocks, if
        any), ``'held-out'``, ``'held-out-2'``, ... (further runs).
    seeds : list of int
        Seeds done for every method.
    seeds_skipped : list of int
        Seeds asked for but left out because of the time budget.
    n_train_part : int
        Samples in the run's training part (before subsampling).
    seconds : float
        Wall time of the training and evaluation, s.
    """

    rows: list[ResultRow]
    fits: dict[str, list[OfflineFit]]
    evaluations: dict[str, Dataset]
    seeds: list[int]
    seeds_skipped: list[int]
    n_train_part: int
    seconds: float

    @property
    def test(self) -> str:
        """The data set of the main test column: ``'held-out'`` if any, else
        ``'validation'`` (or ``'train'`` when there is neither)."""
        for name in ('held-out', 'validation'):
            if name in self.evaluations:
                return name
        return 'train'


def retrain(train_part: Dataset, validation: Dataset, held_out: Sequence[Dataset] = (), *,
            methods: Sequence[str], seeds: Sequence[int], iterations: int, n_samples: int,
            goal: float, time_budget_s: float | None = None,
            progress: Callable[[str], None] | None = None,
            reference: bool = False) -> Retraining:
    """Retrain every method from every seed on a run and evaluate (module docstring).

    Parameters
    ----------
    train_part, validation : Dataset
        The run's samples, X (N, 3n) and Y (N, n), in time order, split into its training
        and validation blocks; ``validation`` may be empty.
    held_out : sequence of Dataset
        Further runs of the same joints, evaluated only.
    methods : sequence of str
        Method keys.
    seeds : sequence of int
        Seeds of the initial weights, at least one.
    iterations : int
        Levenberg–Marquardt iterations.
    n_samples : int
        Samples drawn at random from the training part (0: all).
    goal : float
        Training goal (MSE of the scaled outputs) for the iterations-to-goal column.
    time_budget_s : float, optional
        Wall time after which no new round of seeds is started: a round is skipped when
        the time so far plus the mean time of the rounds done would exceed it. The first
        round always runs.
    progress : callable, optional
        Called with one line per trained network.
    reference : bool
        Add the rows of the SCARA's least-squares reference (only for the SCARA's joints).

    Returns
    -------
    Retraining
    """
    if not seeds:
        raise ValueError('need at least one seed')
    started = time.perf_counter()
    train = train_part.subsample(n_samples, seed=0, name='train') if n_samples else \
        train_part.take(slice(None), 'train')
    evaluations: dict[str, Dataset] = {'train': train}
    if len(validation):
        evaluations['validation'] = validation
    for i, data in enumerate(held_out):
        evaluations['held-out' if i == 0 else f'held-out-{i + 1}'] = data
    arrays = {name: (d.X, d.Y) for name, d in evaluations.items()}
    with single_blas_thread():
        runs = train_offline(train.X, train.Y, {k: v for k, v in arrays.items() if k != 'train'},
                             methods=methods, seeds=seeds, iterations=iterations, goal=goal,
                             time_budget_s=time_budget_s, progress=progress)
    rows = runs.rows
    if reference:
        rows += _reference_rows(train, arrays)
    return Retraining(rows, runs.fits, evaluations, runs.seeds, runs.seeds_skipped,
                      len(train_part), time.perf_counter() - started)


def _reference_rows(train: Dataset, arrays: Mapping[str, tuple[np.ndarray, np.ndarray]]
                    ) -> list[ResultRow]:
    from scara_ident_ros.paper.reference import reference_rows

    try:
        return reference_rows(train.X, train.Y,
                              {k: v for k, v in arrays.items() if k != 'train'})
    except (ValueError, np.linalg.LinAlgError):
        return []
