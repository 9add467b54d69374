"""Network samples (x = [q, q', q''], y = effort) from a recorded joint-state stream.

The acceleration q'' is estimated exactly as the online identifier estimates it: every
message goes, in stamp order, through the identifier's :class:`InputStage` (the sample
checks, a restart at clock gaps, and by default the zero-phase centred estimate of q''); the
samples of histories too short for an estimate are dropped. A network trained on these
samples therefore sees the same inputs offline as it does online.

Training and validation data are split by time, not at random: neighbouring samples at
1 kHz are nearly identical, so a random split would validate on the training data.
"""
from __future__ import annotations

from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.experiments.datasets import Dataset
from scara_ident_ros.identification import (DEFAULT_MAX_GAP_NS, AccelerationEstimate,
                                            InputStage, JointMap)

__all__ = ['JointStateArrays', 'RecordedDataset', 'dataset_from_joint_states', 'time_split']


class JointStateArrays(Protocol):
    """Joint states as arrays, one row per message (what the bag reader returns).

    Attributes
    ----------
    stamp_ns : ndarray of shape (N,) of int64
        ``header.stamp`` of each message, integer nanoseconds.
    names : tuple of str of length n
        The joints, in the column order of the arrays.
    position, velocity, effort : ndarray of shape (N, n)
        q (rad or m), q' (rad/s or m/s) and the measured effort (N·m or N); NaN where a
        message lacks a value. ``effort`` may also have 0 columns (no effort recorded).
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
    """Samples for the network from a recording, with the joints and what was dropped.

    Attributes
    ----------
    names : tuple of str of length n
        Joint names: the order of the columns of ``data.Y`` and of each third of
        ``data.X``.
    data : Dataset
        Stamps (N,), inputs X (N, 3n) = [q, q', q''] and measured efforts Y (N, n), in time
        order, with ``acceleration='estimated'``.
    skipped : dict of str to int
        Messages that gave no sample, per :class:`SkipReason` value (e.g. ``'warming_up'``).
    """

    names: tuple[str, ...]
    data: Dataset
    skipped: dict[str, int]


def dataset_from_joint_states(series: JointStateArrays, *,
                              differentiator: AccelerationEstimate | None = None,
                              max_gap_ns: int = DEFAULT_MAX_GAP_NS,
                              name: str = '') -> RecordedDataset:
    """Turn recorded joint states into network samples the way the identifier does.

    Parameters
    ----------
    series : JointStateArrays
        The recording; rows are taken in stamp order (stable for equal stamps, which the
        sample check then rejects as repeated).
    differentiator : Differentiator or CentredDifferentiator, optional
        Estimator of q''; by default the identifier's, ``CentredDifferentiator(21, 2)``.
    max_gap_ns : int
        A clock jump larger than this (ns) restarts the estimate, as online.
    name : str
        Label of the data set.

    Returns
    -------
    RecordedDataset
        One sample per message with a valid position, velocity and effort and an
        acceleration estimate.
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
    stage = InputStage(JointMap(names, n_joints=n), need_effort=True, max_gap_ns=max_gap_ns,
                       differentiator=differentiator)
    kept, X, Y = stage.batch(stamps, names, position, velocity,
                             effort if effort.shape[1] == n else None)
    data = Dataset(kept, X, Y, 'estimated', name)
    skipped = {reason.value: k for reason, k in stage.skipped.items() if k}
    return RecordedDataset(names, data, skipped)


def time_split(data: Dataset, validation_fraction: float) -> tuple[Dataset, Dataset]:
    """Split samples by time: the last ``validation_fraction`` of the duration validates.

    Parameters
    ----------
    data : Dataset
        Samples in time order.
    validation_fraction : float
        Fraction in [0, 1) of the time span, from its end, kept for validation.

    Returns
    -------
    train, validation : Dataset
        Samples stamped before, and from, ``t_0 + (1 - fraction)·(t_N − t_0)``, named
        ``'train'`` and ``'validation'``; ``validation`` is empty when the fraction is 0 and
        has at least one sample otherwise.
    """
    if not 0.0 <= validation_fraction < 1.0:
        raise ValueError(f'validation fraction must be in [0, 1), got {validation_fraction}')
    n = len(data)
    if n == 0 or validation_fraction == 0.0:
        return data.take(slice(None), 'train'), data.take(slice(0, 0), 'validation')
    t0, t1 = int(data.stamp_ns[0]), int(data.stamp_ns[-1])
    split_ns = t0 + round((1.0 - validation_fraction) * (t1 - t0))
    cut = min(int(np.searchsorted(data.stamp_ns, split_ns, side='left')), n - 1)
    return data.take(slice(0, cut), 'train'), data.take(slice(cut, None), 'validation')
