"""Decode ``sensor_msgs/msg/JointState`` CDR bytes without building message objects.

The layout (XCDR1, after the 4-byte encapsulation header; alignment is relative to
the end of that header)::

    int32 sec, uint32 nanosec            header.stamp
    uint32 len, char[len]                header.frame_id (len counts the NUL)
    uint32 count, count x string         name (each string 4-aligned)
    uint32 count, [8-align] count x f8   position, then velocity, then effort

:func:`split_joint_state` returns the stamp, the bytes of the ``name`` list (equal
bytes mean equal name lists, so a caller decodes each distinct list once) and the
byte spans of the three float arrays: several times faster than rosbags'
``Typestore.deserialize_cdr`` or ``mcap_ros2``'s dynamic decoder (docs/results.md), and
unlike rosbags it also accepts the slack bytes ``rclpy.serialization`` leaves at the
end of a message with an empty array (its size estimate counts the 8-byte alignment of
an empty float64 sequence, which the data never take). ``end`` is where the data really
end: the exact length of the message as Fast DDS sends it, and as rosbags wants it.
Big-endian messages (never produced by Fast DDS on x86/ARM) are left to rosbags.
:func:`header_stamp_ns` reads the stamp of any message that starts with a std_msgs/Header.
"""
from __future__ import annotations

import struct
from typing import NamedTuple

__all__ = ['JointStateSpans', 'decode_names', 'header_stamp_ns', 'split_joint_state']

_UINT32 = struct.Struct('<I').unpack_from
_STAMP = struct.Struct('<iI').unpack_from
_HEADER = 4  # bytes of the CDR encapsulation header
_LITTLE_ENDIAN = 1  # second byte of the encapsulation header: CDR_LE / PL_CDR_LE


class JointStateSpans(NamedTuple):
    """Where the parts of one serialized JointState are.

    Attributes
    ----------
    stamp_ns : int
        ``header.stamp`` in integer nanoseconds.
    names : bytes
        The ``name`` sequence as serialized (count, then length and characters of each
        name) without the padding between names, whose bytes Fast DDS leaves
        uninitialized: equal lists give equal bytes. Decode with :func:`decode_names`.
    position, velocity, effort : tuple of (int, int)
        ``(offset, count)``: ``count`` little-endian float64 values start at byte
        ``offset`` of the message.
    end : int
        Bytes of the message up to the end of its data (encapsulation header included):
        its exact CDR length, without the slack after it.
    """

    stamp_ns: int
    names: bytes
    position: tuple[int, int]
    velocity: tuple[int, int]
    effort: tuple[int, int]
    end: int


def header_stamp_ns(data: bytes) -> int | None:
    """``header.stamp`` in ns of a serialized message that starts with a std_msgs/Header
    (little-endian CDR, as every ROS 2 middleware writes it); None if too short."""
    if len(data) < 12 or data[1] != _LITTLE_ENDIAN:
        return None
    sec, nanosec = _STAMP(data, _HEADER)
    return sec * 1_000_000_000 + nanosec


def split_joint_state(raw: bytes) -> JointStateSpans:
    """Locate the stamp, names and arrays of a serialized little-endian JointState.

    ``raw`` is the CDR message as recorded (encapsulation header included).

    Raises
    ------
    ValueError
        If the message is big-endian, or shorter than its own lengths say.
    """
    if len(raw) < 16 or raw[1] != _LITTLE_ENDIAN:
        raise ValueError('not a little-endian CDR JointState')
    try:
        return _split(raw)
    except struct.error as exc:
        raise ValueError(f'JointState of {len(raw)} bytes is truncated ({exc})') from None


def _split(raw: bytes) -> JointStateSpans:
    size = len(raw)
    sec, nanosec = _STAMP(raw, _HEADER)
    pos = _HEADER + 8
    pos += 4 + _UINT32(raw, pos)[0]  # frame_id
    pos = (pos + 3) & ~3
    count = _UINT32(raw, pos)[0]
    pieces = [raw[pos:pos + 4]]
    pos += 4
    for _ in range(count):
        pos = (pos + 3) & ~3
        end = pos + 4 + _UINT32(raw, pos)[0]
        if end > size:
            raise ValueError('JointState name list runs past the end of the message')
        pieces.append(raw[pos:end])
        pos = end
    names = b''.join(pieces)
    spans = []
    for _ in range(3):
        pos = (pos + 3) & ~3
        count = _UINT32(raw, pos)[0]
        pos += 4
        if count:
            pos = ((pos - _HEADER + 7) & ~7) + _HEADER
        spans.append((pos, count))
        pos += 8 * count
    if pos > size:
        raise ValueError(f'JointState of {size} bytes is truncated (arrays end at {pos})')
    return JointStateSpans(sec * 1_000_000_000 + nanosec, names, spans[0], spans[1], spans[2],
                           pos)


def decode_names(block: bytes) -> tuple[str, ...]:
    """Decode the ``names`` of :class:`JointStateSpans` into joint names."""
    count = _UINT32(block, 0)[0]
    names = []
    pos = 4
    for _ in range(count):
        length = _UINT32(block, pos)[0]
        names.append(block[pos + 4:pos + 4 + max(length - 1, 0)].decode())
        pos += 4 + length
    return tuple(names)
