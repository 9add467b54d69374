"""Joint states of a ROS 1 bag (``.bag``), read with rosbags' ``AnyReader``.

The messages are deserialized one by one (ROS 1 serialization is not CDR, so the fast span
reader of :mod:`scara_ident_ros.bag.joint_states` does not apply) and mapped by joint name
as it maps those of a rosbag2 bag: the topic is the only ``sensor_msgs/JointState`` one or
``/joint_states``, the joints those of the first message with names unless chosen.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.joint_states import JOINT_STATE, JOINT_STATES_TOPIC, JointStateSeries

__all__ = ['read_ros1_joint_states']


def read_ros1_joint_states(path: Path, topic: str | None = None,
                           joints: Sequence[str] | None = None, *,
                           min_samples: int = 2) -> JointStateSeries:
    """Read the JointState messages of a ROS 1 bag into arrays with a fixed joint order.

    Raises
    ------
    BagError
        If the bag cannot be read, has no (unique) JointState topic, or fewer than
        ``min_samples`` messages name any of the joints.
    """
    from rosbags.highlevel import AnyReader

    try:
        with AnyReader([path]) as reader:
            by_topic: dict[str, list[Any]] = {}
            for connection in reader.connections:
                if connection.msgtype == JOINT_STATE:
                    by_topic.setdefault(connection.topic, []).append(connection)
            every = ', '.join(sorted({c.topic for c in reader.connections})) or 'none'
            if topic is None:
                if JOINT_STATES_TOPIC in by_topic or len(by_topic) != 1:
                    topic = JOINT_STATES_TOPIC
                else:
                    topic = next(iter(by_topic))
            if topic not in by_topic:
                raise BagError(f'{path}: no {JOINT_STATE} topic {topic} (its topics: {every})')
            rows = []
            for connection, _, raw in reader.messages(connections=by_topic[topic]):
                msg: Any = reader.deserialize(raw, connection.msgtype)
                stamp = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
                rows.append((stamp, list(msg.name), msg.position, msg.velocity, msg.effort))
    except BagError:
        raise
    except Exception as exc:  # noqa: BLE001 - rosbags raises its own per format
        text = ' '.join(str(exc).split()) or type(exc).__name__
        raise BagError(f'{path}: cannot read the ROS 1 bag ({text})') from None
    wanted = tuple(joints) if joints is not None else next(
        (tuple(names) for _, names, *_ in rows if names), None)
    used = []
    for stamp, names, *arrays in rows:
        if wanted and any(name in wanted for name in names):
            used.append((stamp, names, arrays))
    if wanted is None or len(used) < min_samples:
        raise BagError(f'{path}: {len(used)} usable {JOINT_STATE} message(s) on {topic} of '
                       f'{len(rows)}; need at least {min_samples}')
    column = {name: j for j, name in enumerate(wanted)}
    fields = [np.full((len(used), len(wanted)), np.nan) for _ in range(3)]
    for row, (_, names, arrays) in enumerate(used):
        for field, values in enumerate(arrays):
            if len(values) != len(names):
                continue  # empty (not sent) or malformed: NaN
            for name, value in zip(names, values):
                if name in column:
                    fields[field][row, column[name]] = value
    stamps = np.array([stamp for stamp, _, _ in used], dtype=np.int64)
    return JointStateSeries(topic, wanted, stamps, stamps.copy(), *fields)
