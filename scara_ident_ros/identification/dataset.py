"""Network samples for batch training: inputs X = [q, q', q''] and efforts Y, with stamps.

A data set is plain arrays, whatever made them (a recorded bag, the simulator)::

    stamp_ns : (N,) int64        sample times (ns)
    X        : (N, 3n) float64   [q_1..q_n, q'_1..q'_n, q''_1..q''_n] (rad, m, /s, /s²)
    Y        : (N, n) float64    joint efforts (N·m, N)

q'' is either the simulator's true acceleration (``acceleration='true'``) or estimated
(``'estimated'``) by the identifier's own :class:`InputStage`, in stamp order, so that a
network sees the same inputs offline as online.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from scara_ident_ros.identification.differentiator import AccelerationEstimate
from scara_ident_ros.identification.input_stage import InputStage
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.sample_check import DEFAULT_MAX_GAP_NS
from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['ACCELERATIONS', 'Dataset', 'JointStateArrays', 'RecordedDataset',
           'dataset_from_joint_states', 'make_dataset']

FloatArray = npt.NDArray[np.float64]

#: Where q'' comes from: the simulator's true acceleration, or estimated from q'.
ACCELERATIONS = ('true', 'estimated')

@dataclass(frozen=True)
class Dataset:
    """Samples for identification, with the shapes of the module docstring; ``acceleration``
    says where q'' comes from, ``name`` is a free label (``'train'``)."""

    stamp_ns: npt.NDArray[np.int64]
    X: FloatArray
    Y: FloatArray
    acceleration: str = 'true'
    name: str = field(default='')

    def __post_init__(self) -> None:
        n = self.Y.shape[1] if self.Y.ndim == 2 else -1
        if (self.X.ndim != 2 or n < 1 or self.X.shape != (self.Y.shape[0], 3 * n)
                or self.stamp_ns.shape != (self.Y.shape[0],)):
            raise ValueError(f'need stamp_ns (N,), X (N, 3n), Y (N, n); got '
                             f'{self.stamp_ns.shape}, {self.X.shape}, {self.Y.shape}')
        if self.acceleration not in ACCELERATIONS:
            raise ValueError(f'acceleration must be one of {ACCELERATIONS}, '
                             f'got {self.acceleration!r}')

    def __len__(self) -> int:
        return int(self.Y.shape[0])

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.Y.shape[1])

    @property
    def seconds(self) -> float:
        """Time spanned from the first to the last sample (s)."""
        return float(self.stamp_ns[-1] - self.stamp_ns[0]) * 1e-9 if len(self) else 0.0

    def take(self, index: slice | npt.ArrayLike, name: str | None = None) -> Dataset:
        """Return the samples at ``index`` (a slice, integer indices or a boolean mask)."""
        idx = index if isinstance(index, slice) else np.asarray(index)
        return Dataset(self.stamp_ns[idx], self.X[idx], self.Y[idx], self.acceleration,
                       self.name if name is None else name)

    def head(self, seconds: float, name: str | None = None) -> Dataset:
        """Return the samples stamped within ``seconds`` of the first one."""
        if not len(self):
            return self
        end = self.stamp_ns[0] + round(seconds * 1e9)
        return self.take(slice(0, int(np.searchsorted(self.stamp_ns, end))), name)

    def subsample(self, n_samples: int, *, seed: int = 0, name: str | None = None) -> Dataset:
        """Return ``n_samples`` samples (all if more) drawn without replacement, in time
        order: random, since an even step dividing an excitation's period keeps few states."""
        if n_samples >= len(self):
            return self if name is None else self.take(slice(None), name)
        rng = np.random.default_rng(seed)
        return self.take(np.sort(rng.choice(len(self), n_samples, replace=False)), name)


def make_dataset(stamp_ns: npt.ArrayLike, q: npt.ArrayLike, qd: npt.ArrayLike,
                 effort: npt.ArrayLike, *, qdd: npt.ArrayLike | None = None,
                 differentiator: AccelerationEstimate | None = None, name: str = '') -> Dataset:
    """Build a data set from joint states.

    Parameters
    ----------
    stamp_ns : array_like of shape (N,)
        Sample times (ns).
    q, qd, effort : array_like of shape (N, n)
        Positions (rad, m), velocities (rad/s, m/s) and efforts (N·m, N).
    qdd : array_like of shape (N, n), optional
        True accelerations; if None, q'' is estimated by an :class:`InputStage` with
        ``differentiator`` (default the identifier's) and samples without one are dropped.
    """
    stamps = np.asarray(stamp_ns, dtype=np.int64)
    q = np.asarray(q, dtype=np.float64)
    qd = np.asarray(qd, dtype=np.float64)
    effort = np.asarray(effort, dtype=np.float64)
    if qdd is not None:
        X = np.hstack([q, qd, np.asarray(qdd, dtype=np.float64)])
        return Dataset(stamps, X, effort, 'true', name)
    n = effort.shape[1]
    names = tuple(f'joint{j + 1}' for j in range(n))
    stage = InputStage(JointMap(names, n_joints=n), differentiator=differentiator)
    kept, X, Y = stage.batch(stamps, names, q, qd, effort)
    return Dataset(kept, X, Y, 'estimated', name)


class JointStateArrays(Protocol):
    """Joint states as arrays, one row per message (what the bag reader returns).

    Attributes
    ----------
    stamp_ns : ndarray of shape (N,) of int64
        ``header.stamp`` of each message (ns).
    names : tuple of str of length n
        The joints, in column order.
    position, velocity, effort : ndarray of shape (N, n)
        q (rad or m), q' (rad/s or m/s), effort (N·m or N); NaN where a message lacks a
        value. ``effort`` may have 0 columns (none recorded).
    """

    @property
    def stamp_ns(self) -> NDArray[np.int64]: ...

    @property
    def names(self) -> tuple[str, ...]: ...

    @property
    def position(self) -> NDArray[np.float64]: ...

    @property
    def velocity(self) -> NDArray[np.float64]: ...

    @property
    def effort(self) -> NDArray[np.float64]: ...


class RecordedDataset(NamedTuple):
    """Samples from a recording: the joint ``names`` (column order of ``data.Y`` and of each
    third of ``data.X``), the estimated-q'' ``data``, the messages ``skipped`` per
    :class:`SkipReason` value, and the clock ``gaps`` (each restarted the q'' estimate)."""

    names: tuple[str, ...]
    data: Dataset
    skipped: dict[str, int]
    gaps: int = 0


def dataset_from_joint_states(series: JointStateArrays, *,
                              differentiator: AccelerationEstimate | None = None,
                              max_gap_ns: int = DEFAULT_MAX_GAP_NS,
                              name: str = '') -> RecordedDataset:
    """Turn recorded joint states into network samples the way the identifier does.

    Parameters
    ----------
    series : JointStateArrays
        The recording, taken in stamp order.
    differentiator : AccelerationEstimate, optional
        Estimator of q''; by default the identifier's.
    max_gap_ns : int
        A clock jump larger than this (ns) restarts the estimate, as online.

    Returns
    -------
    RecordedDataset
        One sample per valid message with a q'' estimate. A series with an
        ``acceleration`` array (a table that gives q'') is taken with that q'' instead
        (``data.acceleration`` ``'true'``): every finite row not equal to the previous one.
    """
    names = tuple(str(joint) for joint in series.names)
    n = len(names)
    if n == 0:
        raise ValueError('the joint states name no joints')
    stamps = np.asarray(series.stamp_ns, dtype=np.int64)
    count = stamps.shape[0]
    position = np.asarray(series.position, dtype=np.float64).reshape(count, -1)
    velocity = np.asarray(series.velocity, dtype=np.float64).reshape(count, -1)
    effort = np.asarray(series.effort, dtype=np.float64).reshape(count, -1)
    given = getattr(series, 'acceleration', None)
    if given is not None:
        return _given_accelerations(names, stamps, position, velocity, effort,
                                    np.asarray(given, dtype=np.float64).reshape(count, -1),
                                    name)
    stage = InputStage(JointMap(names, n_joints=n), need_effort=True, max_gap_ns=max_gap_ns,
                       differentiator=differentiator)
    kept, X, Y = stage.batch(stamps, names, position, velocity,
                             effort if effort.shape[1] == n else None)
    data = Dataset(kept, X, Y, 'estimated', name)
    skipped = {reason.value: k for reason, k in stage.skipped.items() if k}
    return RecordedDataset(names, data, skipped, stage.gaps)



def _given_accelerations(names: tuple[str, ...], stamps: NDArray[np.int64],
                         position: FloatArray, velocity: FloatArray, effort: FloatArray,
                         acceleration: FloatArray, name: str) -> RecordedDataset:
    """Samples whose q'' the recording gives (a table): taken as they are, in stamp order,
    but for rows with a non-finite value (``non_finite``) and rows equal to the previous
    kept one (``repeated``)."""
    order = np.argsort(stamps, kind='stable')
    rows = np.hstack([position, velocity, acceleration, effort])[order]
    finite = np.isfinite(rows).all(axis=1)
    keep = finite.copy()
    kept_rows = np.flatnonzero(finite)
    repeated = np.zeros(rows.shape[0], dtype=bool)
    repeated[kept_rows[1:]] = (rows[kept_rows[1:]] == rows[kept_rows[:-1]]).all(axis=1)
    keep &= ~repeated
    n = len(names)
    data = Dataset(stamps[order][keep], rows[keep, :3 * n], rows[keep, 3 * n:], 'true', name)
    counts = {SkipReason.NON_FINITE.value: int((~finite).sum()),
              SkipReason.REPEATED.value: int(repeated.sum())}
    return RecordedDataset(names, data, {k: v for k, v in counts.items() if v})
