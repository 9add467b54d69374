"""The fast JointState decoder agrees with rclpy's own deserialization, byte for byte."""
from __future__ import annotations

import random

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import JointState

from scara_ident_ros.bag.cdr import decode_names, header_stamp_ns, split_joint_state

pytestmark = pytest.mark.ros

STORE = get_typestore(Stores.ROS2_JAZZY)
JOINT_STATE = 'sensor_msgs/msg/JointState'


def random_message(rng: random.Random) -> JointState:
    msg = JointState()
    msg.header.frame_id = 'f' * rng.randrange(0, 7)
    msg.header.stamp.sec = rng.randrange(0, 2**31 - 1)
    msg.header.stamp.nanosec = rng.randrange(0, 10**9)
    n = rng.randrange(0, 8)
    msg.name = ['j' * rng.randrange(0, 9) + str(i) for i in range(n)]
    for field in ('position', 'velocity', 'effort'):
        count = rng.choice([0, n, rng.randrange(0, 9)])
        setattr(msg, field, [rng.uniform(-1e3, 1e3) for _ in range(count)])
    return msg


def test_random_messages_decode_like_rclpy() -> None:
    rng = random.Random(7)
    for _ in range(2000):
        raw = bytes(serialize_message(random_message(rng)))
        ref = deserialize_message(raw, JointState)
        spans = split_joint_state(raw)
        assert spans.stamp_ns == ref.header.stamp.sec * 10**9 + ref.header.stamp.nanosec
        assert decode_names(spans.names) == tuple(ref.name)
        for field in ('position', 'velocity', 'effort'):
            offset, count = getattr(spans, field)
            values = np.frombuffer(raw, '<f8', count, offset)
            np.testing.assert_array_equal(values, np.asarray(getattr(ref, field)))
        # end: the exact CDR length, rosbags' (it writes no slack), which it reads back
        exact = STORE.serialize_cdr(STORE.deserialize_cdr(raw[:spans.end], JOINT_STATE),
                                    JOINT_STATE)
        assert spans.end == len(exact) <= len(raw)


def test_equal_name_lists_give_equal_name_blocks() -> None:
    a, b = JointState(), JointState()
    a.name = b.name = ['shoulder', 'elbow']
    a.position, b.position = [1.0, 2.0], [3.0, 4.0]
    b.header.frame_id = 'base'
    spans = [split_joint_state(bytes(serialize_message(m))) for m in (a, b)]
    assert spans[0].names == spans[1].names


def test_truncated_and_big_endian_messages_are_refused() -> None:
    msg = JointState()
    msg.name = ['a', 'b']
    msg.position = [1.0, 2.0]
    raw = bytes(serialize_message(msg))
    with pytest.raises(ValueError):
        split_joint_state(raw[:30])
    with pytest.raises(ValueError, match='little-endian'):
        split_joint_state(b'\x00\x00' + raw[2:])


def test_header_stamp_of_a_serialized_joint_state() -> None:
    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1_700_000_000, 123_456_789
    msg.name = ['joint1']
    data = bytes(serialize_message(msg))
    assert header_stamp_ns(data) == 1_700_000_000_123_456_789
    assert header_stamp_ns(data[:8]) is None
    assert header_stamp_ns(b'\x00\x00' + data[2:]) is None  # big-endian CDR: not read
