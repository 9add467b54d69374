"""Conversions between ROS messages and numpy at the node boundary.

Times are integer nanoseconds everywhere in the package; only here do they
become ``builtin_interfaces/Time``.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time
from numpy.typing import NDArray
from sensor_msgs.msg import JointState

__all__ = ['NS_PER_S', 'stamp_to_ns', 'ns_to_stamp', 'joint_state', 'floats']

NS_PER_S = 1_000_000_000


def stamp_to_ns(stamp: Time) -> int:
    """Return a ``builtin_interfaces/Time`` as integer nanoseconds."""
    return stamp.sec * NS_PER_S + stamp.nanosec


def ns_to_stamp(stamp_ns: int) -> Time:
    """Return integer nanoseconds as a ``builtin_interfaces/Time``."""
    sec, nanosec = divmod(int(stamp_ns), NS_PER_S)
    return Time(sec=sec, nanosec=nanosec)


def floats(values: Sequence[float]) -> NDArray[np.float64]:
    """View a message's ``float64[]`` field (an ``array.array``) as a float64 array.

    Returns an empty array for an empty field; copies nothing when it can.
    """
    return np.asarray(values, dtype=np.float64)


def joint_state(stamp_ns: int, names: Sequence[str], *,
                position: NDArray[np.float64] | None = None,
                velocity: NDArray[np.float64] | None = None,
                effort: NDArray[np.float64] | None = None,
                frame_id: str = '') -> JointState:
    """Build a ``sensor_msgs/JointState``.

    Parameters
    ----------
    stamp_ns : int
        ``header.stamp`` in nanoseconds.
    names : sequence of str, length n
        Joint names, in the order of the arrays.
    position, velocity, effort : ndarray of shape (n,), optional
        SI units (rad or m; rad/s or m/s; N·m or N). Left empty when None.
    """
    msg = JointState()
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = frame_id
    msg.name = list(names)
    if position is not None:
        msg.position = position.tolist()
    if velocity is not None:
        msg.velocity = velocity.tolist()
    if effort is not None:
        msg.effort = effort.tolist()
    return msg
