"""A recorded run read from a bag into network samples, or one clear error.

Joins the bag reader (:func:`scara_ident_ros.bag.read_joint_states`: any rosbag2 bag, MCAP
or sqlite3, or a bare ``.mcap`` file) and :func:`~scara_ident_ros.identification.dataset.
dataset_from_joint_states` (the identifier's sample check and acceleration estimate), and
refuses recordings with too few usable samples. Every failure is a
:class:`~scara_ident_ros.bag.BagError` or a :class:`RecordingError` whose message is one
line naming the bag.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.identification.dataset import (JointStateArrays, RecordedDataset,
                                                    dataset_from_joint_states)

__all__ = ['MIN_SAMPLES', 'Recording', 'RecordingError', 'load_recording', 'skipped_text']

#: Fewest usable samples accepted: a windowed error and a validation split need some history.
MIN_SAMPLES = 20


class RecordingError(ScaraIdentError, ValueError):
    """A bag was read but its joint states cannot be used (one-line message)."""


class Recording(NamedTuple):
    """Joint states of a bag and the network samples made from them.

    ``series`` holds the messages of ``topic`` as arrays, ``samples`` the network samples.
    """

    path: Path
    topic: str
    series: JointStateArrays
    samples: RecordedDataset


def load_recording(path: Path, *, topic: str | None = None,
                   joints: Sequence[str] | None = None,
                   minimum: int = MIN_SAMPLES) -> Recording:
    """Read joint states from a bag and turn them into network samples.

    ``topic`` and ``joints`` default as :func:`~scara_ident_ros.bag.read_joint_states` says;
    ``minimum`` is the fewest usable samples accepted.

    Raises
    ------
    BagError
        If the bag is missing, unreadable, truncated, or has no (such) JointState topic or
        joints.
    RecordingError
        If a joint of ``joints`` is in no message, no message gives a joint's position,
        velocity or effort, or fewer than ``minimum`` samples are usable.
    """
    from scara_ident_ros.bag import read_joint_states

    path = Path(path)
    series = read_joint_states(path, topic=topic, joints=list(joints) if joints else None)
    name = str(getattr(series, 'topic', None) or topic or 'the JointState topic')
    missing = {field: [joint for j, joint in enumerate(series.names)
                       if np.isnan(getattr(series, field)[:, j]).all()]
               for field in ('position', 'velocity', 'effort')}
    absent = [joint for joint in missing['position']
              if joint in missing['velocity'] and joint in missing['effort']]
    if joints and absent:
        present = read_joint_states(path, topic=name).names
        raise RecordingError(f'{path}: {name} has no joint {", ".join(absent)} (its joints: '
                             f'{", ".join(present)})')
    for field, lacking in missing.items():
        if lacking:
            raise RecordingError(f'{path}: {name} carries no {field} for '
                                 f'{", ".join(lacking)}; the network needs position, velocity '
                                 'and effort of every joint')
    samples = dataset_from_joint_states(series, name=path.name)
    usable = len(samples.data)
    if usable < minimum:
        messages = int(series.stamp_ns.shape[0])
        raise RecordingError(
            f'{path}: {name} has {usable} usable samples of {messages} messages (skipped: '
            f'{skipped_text(samples)}); need at least {minimum}')
    return Recording(path, name, series, samples)


def skipped_text(samples: RecordedDataset) -> str:
    """``'1 warming_up, 3 non_finite'``, or ``'none'``."""
    if not samples.skipped:
        return 'none'
    return ', '.join(f'{count} {reason}' for reason, count
                     in sorted(samples.skipped.items(), key=lambda kv: -kv[1]))
