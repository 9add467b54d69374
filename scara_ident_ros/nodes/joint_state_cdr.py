"""``sensor_msgs/JointState`` at 1 kHz without message objects, both ways.

rclpy turns each received message into Python objects (a list of names, three
``array.array``) and each published one back, field by field, with type checks: at 1 kHz
and one prediction per method that is most of an identifier's message path. Here a
received message is taken raw (``raw=True`` subscriptions) and split where its parts are
(:func:`~scara_ident_ros.bag.cdr.split_joint_state`), the arrays viewed as float64 in
place and the names decoded once per distinct list; a published prediction is serialised
once (:class:`JointStateTemplate`) and only its stamp and efforts are written for each
sample. Big-endian messages (no Fast DDS on x86 or ARM sends them) go through rclpy.
"""
from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState

from scara_ident_ros.bag.cdr import decode_names, split_joint_state
from scara_ident_ros.nodes.messages import NS_PER_S, floats, joint_state, stamp_to_ns

__all__ = ['JointStateReader', 'JointStateTemplate', 'RawJointState']

_STAMP = struct.Struct('<iI')
_STAMP_AT = 4  # bytes: header.stamp follows the CDR encapsulation header
_FRAME = struct.Struct('<I')


class RawJointState(NamedTuple):
    """One received JointState, its arrays float64 views (empty when not sent)."""

    stamp_ns: int
    frame_id: str
    names: tuple[str, ...]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    effort: NDArray[np.float64]


class JointStateReader:
    """Read serialized JointState messages, decoding each distinct name list once."""

    def __init__(self) -> None:
        self._names: dict[bytes, tuple[str, ...]] = {}
        self._frame: tuple[bytes, str] = (b'', '')

    def read(self, raw: bytes) -> RawJointState:
        """The parts of the serialized message ``raw`` (CDR, encapsulation included)."""
        try:
            spans = split_joint_state(raw)
        except ValueError:  # big-endian or malformed: let rclpy say what it is
            return self.of_message(deserialize_message(raw, JointState))
        names = self._names.get(spans.names)
        if names is None:
            if len(self._names) > 64:  # a stream of ever new lists: keep memory bounded
                self._names.clear()
            names = self._names[spans.names] = decode_names(spans.names)
        length = _FRAME.unpack_from(raw, _STAMP_AT + 8)[0]
        frame_bytes = raw[_STAMP_AT + 12:_STAMP_AT + 12 + max(length - 1, 0)]
        if frame_bytes != self._frame[0]:
            self._frame = (frame_bytes, frame_bytes.decode(errors='replace'))
        arrays = [np.frombuffer(raw, '<f8', count, offset)
                  for offset, count in (spans.position, spans.velocity, spans.effort)]
        return RawJointState(spans.stamp_ns, self._frame[1], names, *arrays)

    @staticmethod
    def of_message(msg: JointState) -> RawJointState:
        """The same parts of a message object."""
        return RawJointState(stamp_to_ns(msg.header.stamp), msg.header.frame_id,
                             tuple(msg.name), floats(msg.position), floats(msg.velocity),
                             floats(msg.effort))


class JointStateTemplate:
    """A serialized JointState of fixed names and frame, with efforts only; each
    :meth:`fill` writes a stamp and efforts into it.

    Parameters
    ----------
    names : sequence of str, length n
        The joints, in the order of the efforts.
    frame_id : str
        ``header.frame_id``.
    """

    def __init__(self, names: Sequence[str], frame_id: str = '') -> None:
        n = len(names)
        self.names = tuple(names)
        self.frame_id = frame_id
        self._buffer = bytearray(serialize_message(
            joint_state(0, names, effort=np.zeros(n), frame_id=frame_id)))
        spans = split_joint_state(bytes(self._buffer))
        offset, count = spans.effort
        if count != n:
            raise ValueError(f'serialized JointState has {count} efforts, expected {n}')
        self._efforts = np.frombuffer(self._buffer, '<f8', n, offset)  # writes into it

    def fill(self, stamp_ns: int, effort: NDArray[np.float64]) -> bytes:
        """The serialized message for ``stamp_ns`` (ns) and ``effort`` (n,) (N·m or N)."""
        sec, nanosec = divmod(stamp_ns, NS_PER_S)
        _STAMP.pack_into(self._buffer, _STAMP_AT, sec, nanosec)
        self._efforts[:] = effort
        return bytes(self._buffer)
