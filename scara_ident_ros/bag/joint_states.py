"""Joint states of a bag as arrays, mapped by joint name to a fixed column order.

:func:`read_joint_states` is what offline training reads::

    series = read_joint_states('run1')                 # topic and joints auto-detected
    series.stamp_ns        # (N,) int64, header stamps
    series.position        # (N, n) float64, columns in the order of series.names

The topic is the bag's only ``sensor_msgs/msg/JointState`` topic, or ``/joint_states``
when there are several (e.g. the identifiers' ``/<ns>/identified_torque`` are
JointStates too). The joints are those of the first message with names, unless
``joints`` selects them. Every message is mapped by name: a message with the joints in
another order lands in the same columns; a value a message does not carry (an empty
``velocity``, a joint it does not list) is NaN; a message that names none of the joints
(another publisher on the same topic, e.g. a gripper) is skipped.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from scara_ident_ros.bag.cdr import JointStateSpans, decode_names, split_joint_state
from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.joint_state_series import JointStateSeries
from scara_ident_ros.bag.reader import BagSource, open_bag
from scara_ident_ros.topics import JOINT_STATES, in_namespace

__all__ = ['JOINT_STATE', 'JOINT_STATES_TOPIC', 'JointStateSeries', 'find_joint_state_topic',
           'read_joint_states']

JOINT_STATE = 'sensor_msgs/msg/JointState'
JOINT_STATES_TOPIC = in_namespace(JOINT_STATES)
_FIELDS = ('position', 'velocity', 'effort')


def find_joint_state_topic(bag: BagSource, topic: str | None = None) -> str:
    """Return the JointState topic to read: ``topic`` if given, else the one auto-detected.

    Raises
    ------
    BagError
        If ``topic`` is not a JointState topic of the bag, if there is none, or if there
        are several and none is ``/joint_states``.
    """
    topics = bag.topics
    candidates = [name for name, info in topics.items() if info.msgtype == JOINT_STATE]
    if topic is not None:
        if topic not in candidates:
            raise BagError(f'{bag.path}: {topic} is not a {JOINT_STATE} topic of the bag '
                           f'(it has {bag.describe_topics()})')
        return topic
    if not candidates:
        raise BagError(f'{bag.path}: no {JOINT_STATE} topic (the bag has '
                       f'{bag.describe_topics()})')
    if JOINT_STATES_TOPIC in candidates:
        return JOINT_STATES_TOPIC
    if len(candidates) > 1:
        raise BagError(f'{bag.path}: {len(candidates)} {JOINT_STATE} topics and none is '
                       f'{JOINT_STATES_TOPIC} ({", ".join(candidates)}); choose one with topic=')
    return candidates[0]


class _Layout:
    """How the arrays of messages with one particular name list map to the columns."""

    def __init__(self, names: tuple[str, ...], columns: dict[str, int]) -> None:
        picked = [(i, columns[name]) for i, name in enumerate(names)
                  if name in columns and names.index(name) == i]
        self.width = len(names)
        self.source = np.array([i for i, _ in picked], dtype=np.intp)  # index in the message
        self.target = np.array([c for _, c in picked], dtype=np.intp)  # column of the output
        self.rows: list[list[int]] = [[], [], []]  # per field: output rows with values
        self.data = [bytearray(), bytearray(), bytearray()]  # per field: float64 bytes


def read_joint_states(path: str | Path, topic: str | None = None,
                      joints: Sequence[str] | None = None, *,
                      min_samples: int = 2) -> JointStateSeries:
    """Read the JointState messages of a bag into arrays with a fixed joint order.

    ``topic`` and ``joints`` default as the module docstring says.

    Raises
    ------
    BagError
        If the bag cannot be read, has no (unique) JointState topic, or fewer than
        ``min_samples`` messages name any of the joints.
    """
    with open_bag(path) as bag:
        topic = find_joint_state_topic(bag, topic)
        wanted = tuple(joints) if joints is not None else None
        if wanted is not None and len(set(wanted)) != len(wanted):
            raise BagError(f'{bag.path}: joints {list(wanted)} has duplicates')
        return _read(bag, topic, wanted, min_samples)


def _read(bag: BagSource, topic: str, wanted: tuple[str, ...] | None,
          min_samples: int) -> JointStateSeries:
    layouts: dict[bytes, _Layout | None] = {}
    columns: dict[str, int] = {name: i for i, name in enumerate(wanted or ())}
    stamps: list[int] = []
    log_times: list[int] = []
    seen_names: set[str] = set()
    index = 0
    for message in bag.messages([topic]):
        raw = message.data
        try:
            spans = split_joint_state(raw)
        except ValueError as exc:
            raw, spans = _via_rosbags(bag, raw, index, exc)
        if spans.names in layouts:
            layout = layouts[spans.names]
        else:
            names = decode_names(spans.names)
            seen_names.update(names)
            if wanted is None and names:
                wanted = names
                columns = {name: i for i, name in enumerate(wanted)}
            layout = _Layout(names, columns) if columns else None
            if layout is not None and not layout.source.size:
                layout = None
            if wanted is not None:
                layouts[spans.names] = layout
        index += 1
        if layout is None:
            continue
        row = len(stamps)
        stamps.append(spans.stamp_ns)
        log_times.append(message.log_time_ns)
        for field, (offset, count) in enumerate((spans.position, spans.velocity,
                                                 spans.effort)):
            if count == layout.width:
                layout.rows[field].append(row)
                layout.data[field] += raw[offset:offset + 8 * count]
    if wanted is None or len(stamps) < min_samples:
        found = ', '.join(sorted(seen_names)) or 'none'
        raise BagError(f'{bag.path}: {len(stamps)} usable {JOINT_STATE} message(s) on {topic}'
                       f'{f" naming {list(wanted)}" if wanted else ""} (of {index}; joint names '
                       f'in the messages: {found}); need at least {min_samples}')
    arrays = [np.full((len(stamps), len(wanted)), np.nan) for _ in _FIELDS]
    for layout in layouts.values():
        if layout is None:
            continue
        for field in range(3):
            if not layout.rows[field]:
                continue
            values = np.frombuffer(bytes(layout.data[field]), dtype='<f8')
            values = values.reshape(-1, layout.width)[:, layout.source]
            rows = np.asarray(layout.rows[field], dtype=np.intp)
            arrays[field][rows[:, None], layout.target[None, :]] = values
    return JointStateSeries(topic, wanted, np.asarray(stamps, dtype=np.int64),
                            np.asarray(log_times, dtype=np.int64), *arrays)


def _via_rosbags(bag: BagSource, raw: bytes, index: int, error: Exception
                 ) -> tuple[bytes, JointStateSpans]:
    """Re-encode a message the fast path cannot read (big-endian) as little-endian."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    try:
        message = store.deserialize_cdr(raw, JOINT_STATE)
        little = bytes(store.serialize_cdr(message, JOINT_STATE, little_endian=True))
        return little, split_joint_state(little)
    except Exception as exc:  # noqa: BLE001 - rosbags' SerdeError and struct errors
        raise BagError(f'{bag.path}: JointState message {index} cannot be decoded '
                       f'({error}; {exc})') from exc
