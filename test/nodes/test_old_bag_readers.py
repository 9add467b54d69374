"""A bag of earlier versions, copied by ``scara-ident recover --exact-cdr``, reads in rosbags,
mcap-ros2-support and rclpy, message for message the values of the original (issue 26)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from cdr_readers import READERS, joint_state_fields

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'bag'))

from bag_files import OLD_SLACK, robot, write_old_identifier_bag  # noqa: E402

from scara_ident_ros.bag import open_bag, trim_bag  # noqa: E402

pytestmark = pytest.mark.ros


def test_every_reader_reads_every_message_of_the_copy(tmp_path: Path) -> None:
    written = write_old_identifier_bag(tmp_path / 'old', robot(4, 100, seed=2),
                                       methods=('ffs', 'ffmw'))
    old = tmp_path / 'old'
    with pytest.raises(Exception, match='size mismatch'):
        READERS['rosbags'](written['/ffs/identified_torque'][0][1], 'sensor_msgs/msg/JointState')
    trim_bag(old, tmp_path / 'fixed')
    with open_bag(old) as before, open_bag(tmp_path / 'fixed') as after:
        pairs = list(zip(before.messages(), after.messages(), strict=True))
    assert len(pairs) == sum(map(len, written.values()))
    cut = 0
    for original, copy in pairs:
        assert (copy.topic, copy.msgtype, copy.log_time_ns) == (
            original.topic, original.msgtype, original.log_time_ns)
        cut += len(original.data) - len(copy.data)
        decoded = {name: read(copy.data, copy.msgtype) for name, read in READERS.items()}
        if copy.msgtype == 'sensor_msgs/msg/JointState':
            expected = joint_state_fields(deserialize_message(original.data, JointState))
            for name, msg in decoded.items():
                assert joint_state_fields(msg) == expected, (name, copy.topic)
        else:
            values = {name: [float(v) for v in msg.data] for name, msg in decoded.items()}
            assert len({tuple(v) for v in values.values()}) == 1, values
    assert cut == 2 * 2 * 100 * len(OLD_SLACK)  # 2 methods x 2 topics x 100 messages
