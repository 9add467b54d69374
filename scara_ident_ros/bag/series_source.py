"""A recording that is not a rosbag2 bag, played like one: its joint states as JointStates.

The ``player`` node plays raw messages of a :class:`~scara_ident_ros.bag.BagSource`. For a
ROS 1 bag or a table (:func:`~scara_ident_ros.bag.recording_file.read_recording`),
:func:`open_recording_source` gives a :class:`SeriesSource` with the same interface and
one topic, ``/joint_states``: one ``sensor_msgs/msg/JointState`` per sample, stamped and
timed by the sample's stamp (so played at the recording's own timing), in CDR as a rosbag2
bag holds it. q' derived from q (a recording without velocities) is published as if
measured; q'' is never published (JointState has no field for it): the identifier
estimates it from q'. A rosbag2 bag is opened as it is (:func:`~scara_ident_ros.bag.open_bag`).
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.joint_states import JOINT_STATE, JOINT_STATES_TOPIC
from scara_ident_ros.bag.reader import BagMessage, BagSource, TopicInfo, open_bag
from scara_ident_ros.bag.recording_file import (RecordingSeries, read_recording,
                                                recording_kind, split_name)

__all__ = ['SeriesSource', 'open_recording_source']


class SeriesSource:
    """A recording's joint states as the messages of one JointState topic.

    Parameters
    ----------
    series : RecordingSeries
        What is played, sample by sample in stamp order.
    topic : str
        The topic they are played on.
    """

    def __init__(self, series: RecordingSeries, topic: str = JOINT_STATES_TOPIC) -> None:
        self.path = series.path
        self.series = series
        self.topic = topic
        self._order = np.argsort(series.stamp_ns, kind='stable')
        from rosbags.typesys import Stores, get_typestore

        # Now, not on the first message: building it takes a while, and the player's clock
        # runs from before the first message.
        self._store = get_typestore(Stores.ROS2_JAZZY)

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """The one topic and its message count."""
        return {self.topic: TopicInfo(JOINT_STATE, len(self.series))}

    @property
    def message_count(self) -> int:
        """Messages to play: one per sample."""
        return len(self.series)

    @property
    def start_ns(self) -> int:
        """Stamp of the first sample (ns)."""
        return int(self.series.stamp_ns[self._order[0]]) if len(self.series) else 0

    @property
    def end_ns(self) -> int:
        """Stamp of the last sample (ns)."""
        return int(self.series.stamp_ns[self._order[-1]]) if len(self.series) else 0

    def offered_qos(self, topic: str) -> list[Any]:
        """No recorded publisher offered anything: the player's defaults apply."""
        return []

    def describe_topics(self) -> str:
        """One line, as :meth:`BagSource.describe_topics`."""
        return f'{self.topic} ({JOINT_STATE}, {len(self.series)} msgs)'

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[BagMessage]:
        """Yield one serialized JointState per sample, in stamp order.

        Raises
        ------
        BagError
            If another topic than :attr:`topic` is asked for.
        """
        if topics is not None:
            wanted = set(topics)
            if wanted - {self.topic}:
                raise BagError(f'{self.path}: no topic {", ".join(sorted(wanted))} '
                               f'(it has {self.describe_topics()})')
            if not wanted:
                return
        store = self._store
        JointState = store.types[JOINT_STATE]
        Header = store.types['std_msgs/msg/Header']
        Time = store.types['builtin_interfaces/msg/Time']
        series = self.series
        names = list(series.names)
        empty = np.empty(0)
        for i in self._order.tolist():
            stamp = int(series.stamp_ns[i])
            sec, nanosec = divmod(stamp, 1_000_000_000)
            velocity = series.velocity[i]
            effort = series.effort[i]
            msg = JointState(Header(Time(sec, nanosec), ''), names,
                             np.ascontiguousarray(series.position[i]),
                             empty if np.isnan(velocity).all() else velocity.copy(),
                             empty if np.isnan(effort).all() else effort.copy())
            data = bytes(store.serialize_cdr(msg, JOINT_STATE))
            yield BagMessage(self.topic, JOINT_STATE, stamp, data)

    def close(self) -> None:
        """Nothing to close: the recording was read at once."""

    def __enter__(self) -> SeriesSource:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()


def open_recording_source(path: str | Path) -> BagSource | SeriesSource:
    """Open any recording for playing: a rosbag2 bag as it is, anything else as its
    joint states (module docstring).

    Raises
    ------
    BagError
        If the recording cannot be read.
    """
    file, _ = split_name(path)
    if recording_kind(file) == 'rosbag2':
        return open_bag(file)
    return SeriesSource(read_recording(path))
