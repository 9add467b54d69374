"""Backward stamps (interleaved publishers) and the stamp read from serialized bytes."""
from __future__ import annotations

from scara_ident_ros.identification.stamp_order import (INTERLEAVED_STEPS, StampOrder,
                                                        header_stamp_ns)

MS = 1_000_000  # ns


def test_one_publisher_never_goes_back_and_a_restart_goes_back_once() -> None:
    order = StampOrder()
    for k in [*range(100), *range(50)]:  # a simulator restarted at 0
        order.observe(k * MS)
    assert order.backward == 1
    assert order.since_last_look() == 1 < INTERLEAVED_STEPS
    assert order.since_last_look() == 0


def test_two_interleaved_publishers_go_back_every_other_sample() -> None:
    order = StampOrder()
    for k in range(100):
        order.observe(k * MS)  # the first simulator
        order.observe(5_000 * MS + k * MS)  # the second, started 5 s later
    assert order.since_last_look() == 99 >= INTERLEAVED_STEPS


def test_header_stamp_of_a_serialized_joint_state() -> None:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1_700_000_000, 123_456_789
    msg.name = ['joint1']
    data = bytes(serialize_message(msg))
    assert header_stamp_ns(data) == 1_700_000_000_123_456_789
    assert header_stamp_ns(data[:8]) is None
    assert header_stamp_ns(b'\x00\x00' + data[2:]) is None  # big-endian CDR: not read
