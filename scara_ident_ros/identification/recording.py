"""A recorded run read from a bag or a table into network samples, or one clear error.

Joins the reader of recordings (:func:`scara_ident_ros.bag.recording_file.read_recording`:
rosbag2 bags, MCAP or sqlite3, bare ``.mcap`` files, ROS 1 bags, ``.npz`` and CSV tables)
and :func:`~scara_ident_ros.identification.dataset.dataset_from_joint_states` (the
identifier's sample check and acceleration estimate), and
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
from scara_ident_ros.identification.centred_differentiator import (CentredDifferentiator,
                                                                   recording_window)
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
    """Read joint states from any recording and turn them into network samples.

    ``path`` is anything :func:`~scara_ident_ros.bag.recording_file.read_recording` reads
    (rosbag2 or ROS 1 bag, ``.npz``/CSV table, ``FILE.npz:SPLIT``); ``topic`` and ``joints``
    default as it says; ``minimum`` is the fewest usable samples accepted. q' (where the
    recording has none) and q'' are fitted over
    :func:`~scara_ident_ros.identification.centred_differentiator.recording_window` samples:
    the identifier's 21 at 1 kHz and below, 20 ms at faster rates.

    Raises
    ------
    BagError
        If the recording is missing, unreadable, truncated, or has no (such) JointState
        topic or joints.
    RecordingError
        If a joint of ``joints`` is in no message, no message gives a joint's position or
        effort, or fewer than ``minimum`` samples are usable.
    """
    from scara_ident_ros.bag.recording_file import read_recording

    series = read_recording(path, topic=topic, joints=list(joints) if joints else None)
    path = Path(path)
    name = str(getattr(series, 'topic', None) or topic or 'the JointState topic')
    missing = {field: [joint for j, joint in enumerate(series.names)
                       if np.isnan(getattr(series, field)[:, j]).all()]
               for field in ('position', 'velocity', 'effort')}
    absent = [joint for joint in missing['position']
              if joint in missing['velocity'] and joint in missing['effort']]
    if joints and absent:
        present = read_recording(path, topic=topic, derive=False).names
        raise RecordingError(f'{path}: {name} has no joint {", ".join(absent)} (its joints: '
                             f'{", ".join(present)})')
    for field, lacking in missing.items():
        if lacking:
            raise RecordingError(f'{path}: {name} carries no {field} for '
                                 f'{", ".join(lacking)}; the network needs position, velocity '
                                 'and effort of every joint')
    window = recording_window(series.stamp_ns)
    samples = dataset_from_joint_states(series, name=path.name,
                                        differentiator=CentredDifferentiator(window=window))
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
