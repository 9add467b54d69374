"""Joint states as arrays, one row per message: what every reader of recordings returns.

Its own module, free of bag libraries, so that :mod:`~scara_ident_ros.bag.recording_file`
(which extends it) imports it without importing a bag reader.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ['JointStateSeries']


@dataclass(frozen=True)
class JointStateSeries:
    """Joint states of one topic, one row per message, in the order they were recorded.

    :func:`~scara_ident_ros.bag.read_joint_states` returns one for a bag;
    :class:`~scara_ident_ros.bag.recording_file.RecordingSeries` extends it for any recording.

    Attributes
    ----------
    topic : str
        The topic they were read from.
    names : tuple of str of length n
        The joints, in the column order of the arrays.
    stamp_ns : ndarray of shape (N,) of int64
        ``header.stamp`` of each message, integer nanoseconds.
    log_time_ns : ndarray of shape (N,) of int64
        When each message was recorded (reception time), integer nanoseconds.
    position, velocity, effort : ndarray of shape (N, n) of float64
        q (rad or m), q' (rad/s or m/s) and effort (N·m or N); NaN where a message
        lacks the value.
    """

    topic: str
    names: tuple[str, ...]
    stamp_ns: NDArray[np.int64]
    log_time_ns: NDArray[np.int64]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    effort: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.stamp_ns.shape[0])
