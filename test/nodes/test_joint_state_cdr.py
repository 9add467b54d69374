"""The identifier's once-serialized JointState: its messages are what rclpy would send, at
the exact CDR length, and every reader takes them (issue 26: rosbags refused the slack
bytes ``serialize_message`` leaves after an empty array)."""
from __future__ import annotations

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from rosbags.serde import SerdeError
from sensor_msgs.msg import JointState

from cdr_readers import READERS, STORE, joint_state_fields
from scara_ident_ros.bag.cdr import split_joint_state
from scara_ident_ros.nodes.joint_state_cdr import JointStateReader, JointStateTemplate
from scara_ident_ros.nodes.messages import joint_state

pytestmark = pytest.mark.ros

JOINT_STATE = 'sensor_msgs/msg/JointState'
SHAPES = [(n, state) for n in (0, 1, 4, 7) for state in (False, True)]
STAMP_NS = 1_700_000_000_123_456_789


def names_of(n: int) -> list[str]:
    """Joint names of lengths 1, 2, 3 ... so that the names need padding between them."""
    return ['j' * (i + 1) for i in range(n)]


def rosbags_bytes(msg: JointState) -> bytes:
    """``msg`` serialized by rosbags (an independent serializer)."""
    types = STORE.types
    header = types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=msg.header.stamp.sec,
                                                   nanosec=msg.header.stamp.nanosec),
        frame_id=msg.header.frame_id)
    ours = types[JOINT_STATE](header=header, name=list(msg.name),
                              **{key: np.array(getattr(msg, key), np.float64)
                                 for key in ('position', 'velocity', 'effort')})
    return bytes(STORE.serialize_cdr(ours, JOINT_STATE))


@pytest.mark.parametrize('n, state', SHAPES)
@pytest.mark.parametrize('frame_id', ['', 'base_link'])
def test_template_bytes_are_rclpys_message_at_its_exact_length(n: int, state: bool,
                                                              frame_id: str) -> None:
    rng = np.random.default_rng(n)
    names = names_of(n)
    template = JointStateTemplate(names, frame_id, state=state)
    for _ in range(3):  # a template is reused: each fill stands on its own
        effort = rng.standard_normal(n)
        x = rng.standard_normal(3 * n)  # [q, q', q'']
        data = template.fill(STAMP_NS, effort, x if state else None)
        msg = joint_state(STAMP_NS, names, effort=effort, frame_id=frame_id,
                          position=x[:n] if state else None,
                          velocity=x[n:2 * n] if state else None)
        # rosbags' serializer writes no slack: its length is the exact CDR length
        exact = rosbags_bytes(msg)
        assert len(data) == len(exact) == template.size
        assert split_joint_state(data).end == len(data)
        # the same bytes as rclpy's, but for the padding (rclpy leaves it uninitialized: between
        # names, and before an array's first float64 after an empty array's count)
        spans = split_joint_state(data)
        reference = bytes(serialize_message(msg))
        ref = split_joint_state(reference)
        assert data[:12] == reference[:12]
        assert (spans.stamp_ns, spans.names, spans.end) == (ref.stamp_ns, ref.names, ref.end)
        for (mine, count), (theirs, their_count) in zip(
                (spans.position, spans.velocity, spans.effort),
                (ref.position, ref.velocity, ref.effort), strict=True):
            assert (mine, count) == (theirs, their_count)
            assert data[mine:mine + 8 * count] == reference[theirs:theirs + 8 * count]
        expected = joint_state_fields(msg)
        for reader, decode in READERS.items():
            assert joint_state_fields(decode(data, JOINT_STATE)) == expected, reader


@pytest.mark.parametrize('n, state', SHAPES)
def test_template_bytes_read_back_in_the_identifiers_reader(n: int, state: bool) -> None:
    effort, x = np.arange(n) + 0.5, np.arange(3 * n) - 2.5
    template = JointStateTemplate(names_of(n), 'f', state=state)
    raw = JointStateReader().read(template.fill(STAMP_NS, effort, x if state else None))
    assert raw.stamp_ns == STAMP_NS and raw.frame_id == 'f' and raw.names == tuple(names_of(n))
    np.testing.assert_array_equal(raw.effort, effort)
    np.testing.assert_array_equal(raw.position, x[:n] if state else [])
    np.testing.assert_array_equal(raw.velocity, x[n:2 * n] if state else [])


def test_rclpys_slack_bytes_are_what_rosbags_refuses() -> None:
    """The bug of issue 26, kept as the reason for the exact length: with empty position
    and velocity, ``serialize_message`` gives 8 bytes more than the data."""
    msg = joint_state(STAMP_NS, names_of(4), effort=np.ones(4))
    slack = bytes(serialize_message(msg))
    exact = JointStateTemplate(names_of(4)).fill(STAMP_NS, np.ones(4))
    assert len(slack) == len(exact) + 8
    with pytest.raises(SerdeError, match='size mismatch'):
        STORE.deserialize_cdr(slack, JOINT_STATE)
    assert list(STORE.deserialize_cdr(exact, JOINT_STATE).effort) == [1.0] * 4


def test_converts_other_float_types() -> None:
    template = JointStateTemplate(names_of(2), state=True)
    data = template.fill(STAMP_NS, np.array([1.5, 2.5], np.float32), np.arange(6))
    msg = STORE.deserialize_cdr(data, JOINT_STATE)
    assert list(msg.effort) == [1.5, 2.5] and list(msg.position) == [0.0, 1.0]
    assert list(msg.velocity) == [2.0, 3.0]


@pytest.mark.parametrize('state', [False, True])
def test_wrong_lengths_are_refused(state: bool) -> None:
    template = JointStateTemplate(names_of(3), state=state)
    x = np.zeros(9) if state else None
    with pytest.raises(ValueError, match='3 joints filled with 2 efforts'):
        template.fill(STAMP_NS, np.zeros(2), x)
    if state:
        with pytest.raises(ValueError, match='a state of 5'):
            template.fill(STAMP_NS, np.zeros(3), np.zeros(5))
    with pytest.raises(ValueError, match='fill needs the state' if state else 'no state'):
        template.fill(STAMP_NS, np.zeros(3), None if state else np.zeros(9))
