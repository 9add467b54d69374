"""``sensor_msgs/JointState`` at 1 kHz without message objects, both ways.

rclpy turns each received message into Python objects (a list of names, three
``array.array``) and each published one back, field by field, with type checks: at 1 kHz
and one prediction per method that is most of an identifier's message path. Here a
received message is taken raw (``raw=True`` subscriptions) and split where its parts are
(:func:`~scara_ident_ros.bag.cdr.split_joint_state`), the arrays viewed as float64 in
place and the names decoded once per distinct list; a published prediction is serialised
once (:class:`JointStateTemplate`) and only its stamp and arrays are written for each
sample. Big-endian messages (no Fast DDS on x86 or ARM sends them) go through rclpy.

A template holds the message's exact CDR length, as Fast DDS itself sends a published
message and rosbag2 records it: ``rclpy.serialization.serialize_message`` leaves up to 8
slack bytes after a message with an empty float64 array, which a raw publication would
send and a recorder keep, and which rosbags refuses (``CDR message size mismatch``).
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
_FLOAT64 = np.dtype('<f8')


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
    """A serialized JointState of fixed names and frame; :meth:`fill` gives it for a stamp,
    efforts and, with ``state``, positions and velocities.

    The fixed bytes (encapsulation, frame, names, array lengths and alignment) are rclpy's
    serialization, cut to the exact CDR length (see the module's docstring), so every
    reader takes the messages: rclpy, rosbags, ``mcap_ros2``. A message is these pieces
    joined with the stamp and the arrays' bytes, in one copy.

    Parameters
    ----------
    names : sequence of str, length n
        The joints, in the order of the arrays.
    frame_id : str
        ``header.frame_id``.
    state : bool
        Carry ``position`` and ``velocity`` (n each) beside ``effort``; False: they are
        empty.
    """

    def __init__(self, names: Sequence[str], frame_id: str = '', *,
                 state: bool = False) -> None:
        n = len(names)
        self.names = tuple(names)
        self.frame_id = frame_id
        self.state = state
        carried = ('position', 'velocity', 'effort') if state else ('effort',)
        raw = bytes(serialize_message(joint_state(
            0, names, frame_id=frame_id, **{key: np.zeros(n) for key in carried})))
        spans = split_joint_state(raw)
        for key in ('position', 'velocity', 'effort'):
            count, expected = getattr(spans, key)[1], n if key in carried else 0
            if count != expected:
                raise ValueError(f'serialized JointState has {count} values of {key}, '
                                 f'expected {expected}')
        # the bytes around the stamp and the carried arrays, in order
        starts = [getattr(spans, key)[0] for key in carried]
        ends = [_STAMP_AT + _STAMP.size] + [start + 8 * n for start in starts]
        self._head = raw[:_STAMP_AT]
        self._gaps = tuple(raw[end:start] for end, start in zip(ends, starts))
        self._tail = raw[ends[-1]:spans.end]
        self._k = 8 * n  # bytes of one array
        self.size = spans.end  # bytes of every message: the exact CDR length

    def fill(self, stamp_ns: int, effort: NDArray[np.float64],
             state: NDArray[np.float64] | None = None) -> bytes:
        """The serialized message.

        Parameters
        ----------
        stamp_ns : int
            ``header.stamp`` (ns).
        effort : ndarray of shape (n,)
            N·m or N.
        state : ndarray of shape (m,), m >= 2n; only and always with ``state``
            q (rad or m) in its first n values, q' (rad/s or m/s) in the next n: the
            network input ``[q, q', q'']`` as it is.

        Raises
        ------
        ValueError
            If the arrays are too short or long, or ``state`` is given to a template
            without (or not given to one with).
        """
        if effort.dtype != _FLOAT64 or (state is not None and state.dtype != _FLOAT64):
            effort = np.asarray(effort, _FLOAT64)
            state = None if state is None else np.asarray(state, _FLOAT64)
        stamp = _STAMP.pack(*divmod(stamp_ns, NS_PER_S))
        if state is None and not self.state:
            gap, = self._gaps
            data = b''.join((self._head, stamp, gap, effort.tobytes(), self._tail))
        elif state is not None and self.state:
            k = self._k
            q_qd = state.tobytes()
            before_q, before_qd, before_effort = self._gaps
            data = b''.join((self._head, stamp, before_q, q_qd[:k], before_qd, q_qd[k:2 * k],
                             before_effort, effort.tobytes(), self._tail))
        else:
            raise ValueError('this JointStateTemplate carries '
                             + ('position and velocity: fill needs the state' if self.state
                                else 'efforts only: fill takes no state'))
        if len(data) != self.size:
            raise ValueError(f'JointStateTemplate of {len(self.names)} joints filled with '
                             f'{len(effort)} efforts' + ('' if state is None else
                                                         f' and a state of {len(state)}'))
        return data
