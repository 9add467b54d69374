"""Result rows of the comparison tables and their summaries over seeds.

One `ResultRow` is one trained model (a method and a seed, or the least-squares reference)
evaluated on one data set; it is what the CSV files hold, one line each. `summarise` groups
rows by (table, method, data) and gives the median and the min–max spread over seeds.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scara_ident_ros.identification import ErrorStats

__all__ = ['HOLD', 'REFERENCE', 'ResultRow', 'Spread', 'Summary', 'summarise']

#: Method label of the model-based (least-squares) reference rows.
REFERENCE = 'LS'
#: Method label of the trivial online baseline: predict the previous sample's effort.
HOLD = 'hold'


@dataclass(frozen=True)
class ResultRow:
    """One model evaluated on one data set.

    Attributes
    ----------
    table : str
        ``'offline'`` (Table 2 analog) or ``'online'`` (Table 3 analog).
    method : str
        ``'FFMW'``, ``'FFW'``, ``'FFS'``, :data:`REFERENCE` or :data:`HOLD`.
    seed : int or None
        None for the reference.
    data : str
        What was evaluated, e.g. ``'train'``, ``'held-out'``, ``'stream-last-100'``.
    mse, nmse : tuple of float, length n_joints
        Per-joint MSE ((N·m)², N²) and NMSE (MSE / effort variance), see
        :mod:`scara_ident_ros.identification.metrics`.
    mse_mean, nmse_mean : float
        Their means over the joints.
    iterations : int or None
        Offline: training iterations done; online: samples learnt.
    goal, goal_iteration : float or None, int or None
        Offline training goal (scaled MSE) and the first iteration that reached it.
    train_time_s, cpu_time_s : float or None
        Wall and CPU time of training (s).
    diverged : bool
        Training stopped on a non-finite step; the metrics are then NaN.
    """

    table: str
    method: str
    seed: int | None
    data: str
    n_samples: int
    mse: tuple[float, ...]
    nmse: tuple[float, ...]
    mse_mean: float
    nmse_mean: float
    iterations: int | None = None
    goal: float | None = None
    goal_iteration: int | None = None
    train_time_s: float | None = None
    cpu_time_s: float | None = None
    diverged: bool = False
    note: str = ''

    @classmethod
    def from_stats(cls, stats: ErrorStats, *, table: str, method: str, seed: int | None,
                   data: str, **extra: Any) -> ResultRow:
        """Build a row from error statistics; ``extra`` sets the optional fields."""
        return cls(table=table, method=method, seed=seed, data=data, n_samples=stats.count,
                   mse=tuple(float(v) for v in stats.mse),
                   nmse=tuple(float(v) for v in stats.nmse),
                   mse_mean=float(stats.mse_total), nmse_mean=float(stats.nmse_total),
                   **extra)

    @property
    def n_joints(self) -> int:
        """Number of joints."""
        return len(self.mse)

    @property
    def goal_reached(self) -> bool:
        """Whether the training MSE reached the goal."""
        return self.goal_iteration is not None

    def to_dict(self, joint_names: Sequence[str] | None = None) -> dict[str, object]:
        """Flat mapping for a CSV line: per-joint columns ``mse_<joint>``, ``nmse_<joint>``.

        Parameters
        ----------
        joint_names : sequence of str, optional
            Column suffixes; default ``'1'``, ``'2'``, ...
        """
        names = _joint_names(self.n_joints, joint_names)
        out: dict[str, object] = {'table': self.table, 'method': self.method,
                                  'seed': '' if self.seed is None else self.seed,
                                  'data': self.data, 'n_samples': self.n_samples,
                                  'mse_mean': self.mse_mean, 'nmse_mean': self.nmse_mean}
        out.update({f'mse_{name}': value for name, value in zip(names, self.mse)})
        out.update({f'nmse_{name}': value for name, value in zip(names, self.nmse)})
        out.update({'iterations': _blank(self.iterations), 'goal': _blank(self.goal),
                    'goal_reached': self.goal_reached if self.goal is not None else '',
                    'goal_iteration': _blank(self.goal_iteration),
                    'train_time_s': _blank(self.train_time_s),
                    'cpu_time_s': _blank(self.cpu_time_s), 'diverged': self.diverged,
                    'note': self.note})
        return out


def _blank(value: object) -> object:
    return '' if value is None else value


def _joint_names(n: int, joint_names: Sequence[str] | None) -> list[str]:
    if joint_names is None:
        return [str(i + 1) for i in range(n)]
    if len(joint_names) != n:
        raise ValueError(f'need {n} joint names, got {len(joint_names)}')
    return list(joint_names)


@dataclass(frozen=True)
class Spread:
    """Median, minimum and maximum of a quantity over runs, and the ``count`` of finite
    values summarised (NaN ignored; all NaN when none is finite)."""

    median: float
    low: float
    high: float
    count: int

    @classmethod
    def of(cls, values: Iterable[float | None]) -> Spread:
        """Summarise ``values``, skipping None and non-finite ones."""
        finite = np.array([v for v in values if v is not None and math.isfinite(v)], float)
        if finite.size == 0:
            return cls(math.nan, math.nan, math.nan, 0)
        return cls(float(np.median(finite)), float(finite.min()), float(finite.max()),
                   int(finite.size))


@dataclass(frozen=True)
class Summary:
    """The rows of one (table, method, data) summarised over seeds: a `Spread` of each
    `ResultRow` figure (per joint for ``mse``, ``nmse``; count 0 for absent optional
    fields), ``n_samples`` and ``goal`` of the first row, and how many rows reached the
    goal and diverged."""

    table: str
    method: str
    data: str
    n_runs: int
    n_samples: int
    mse_mean: Spread
    nmse_mean: Spread
    mse: tuple[Spread, ...]
    nmse: tuple[Spread, ...]
    iterations: Spread
    goal_iteration: Spread
    train_time_s: Spread
    cpu_time_s: Spread
    goal: float | None
    goal_reached: int
    diverged: int


def summarise(rows: Iterable[ResultRow]) -> list[Summary]:
    """Group rows by (table, method, data), in order of first appearance, and summarise."""
    groups: dict[tuple[str, str, str], list[ResultRow]] = {}
    for row in rows:
        groups.setdefault((row.table, row.method, row.data), []).append(row)
    out = []
    for (table, method, data), group in groups.items():
        n_joints = group[0].n_joints
        out.append(Summary(
            table=table, method=method, data=data, n_runs=len(group),
            n_samples=group[0].n_samples,
            mse_mean=Spread.of(r.mse_mean for r in group),
            nmse_mean=Spread.of(r.nmse_mean for r in group),
            mse=tuple(Spread.of(r.mse[j] for r in group) for j in range(n_joints)),
            nmse=tuple(Spread.of(r.nmse[j] for r in group) for j in range(n_joints)),
            iterations=Spread.of(r.iterations for r in group),
            goal_iteration=Spread.of(r.goal_iteration for r in group),
            train_time_s=Spread.of(r.train_time_s for r in group),
            cpu_time_s=Spread.of(r.cpu_time_s for r in group),
            goal=group[0].goal,
            goal_reached=sum(r.goal_reached for r in group),
            diverged=sum(r.diverged for r in group)))
    return out
