"""Stamps that go back in time: the trace two interleaved publishers leave in one stream.

One publisher's stamps only go forward (a restarted simulator or a looping player goes
back once). Two publishers on one topic (a second simulator on the same ROS domain)
interleave two timelines, and the stream goes back in time about every other sample.
:class:`StampOrder` counts the backward steps; a node looks at the count now and then
and reports a second publisher when it grows by :data:`INTERLEAVED_STEPS` or more.
"""
from __future__ import annotations

import struct

__all__ = ['INTERLEAVED_STEPS', 'StampOrder', 'header_stamp_ns']

INTERLEAVED_STEPS = 3  # backward steps within one look that mean interleaved publishers
_CDR_HEADER_STAMP = struct.Struct('<iI')  # std_msgs/Header.stamp after the 4-byte CDR header


def header_stamp_ns(data: bytes) -> int | None:
    """``header.stamp`` in ns of a serialized message that starts with a std_msgs/Header
    (little-endian CDR, as every ROS 2 middleware writes it); None if too short."""
    if len(data) < 12 or data[1] != 1:  # encapsulation kind 1: CDR little-endian
        return None
    sec, nanosec = _CDR_HEADER_STAMP.unpack_from(data, 4)
    return sec * 1_000_000_000 + nanosec


class StampOrder:
    """Count the samples whose stamp is earlier than the one before.

    Attributes
    ----------
    backward : int
        Backward steps since the start.
    """

    def __init__(self) -> None:
        self.backward = 0
        self._last: int | None = None
        self._seen = 0  # backward steps at the last look

    def observe(self, stamp_ns: int) -> None:
        """Take the stamp of the next sample, in ns."""
        if self._last is not None and stamp_ns < self._last:
            self.backward += 1
        self._last = stamp_ns

    def since_last_look(self) -> int:
        """Backward steps since the previous call."""
        steps, self._seen = self.backward - self._seen, self.backward
        return steps
