"""The Table 2 analog from a recorded run: each method retrained offline from several seeds.

The run's samples come split as ``scara-ident train`` splits them
(:func:`~scara_ident_ros.identification.split.block_split`); ``samples`` random samples of
the training part (the same for every method and seed) train each network
(:func:`scara_ident_ros.paper.table2.train_offline`, rounds of seeds, BLAS on one thread),
and the validation blocks and any held-out runs are evaluated. With ``reference=True`` the
SCARA's least-squares reference (LS) is added.
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
    rows, fits, seeds, seeds_skipped
        As in :class:`~scara_ident_ros.paper.table2.OfflineRuns`, plus the LS rows.
    evaluations : dict of str to Dataset
        ``'train'``, ``'validation'`` (if any), ``'held-out'``, ``'held-out-2'``, ...
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

    ``train_part`` and ``validation`` (may be empty) are the run's blocks, ``held_out``
    further runs of the same joints, evaluated only; ``n_samples`` (0: all) are drawn from
    the training part; the other options are those of
    :func:`~scara_ident_ros.paper.table2.train_offline`.
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
