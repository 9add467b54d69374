"""The recorder's services (``~/split``, ``~/pause``, ``~/resume``) and its ``/diagnostics``.

The recorder runs in its own process; the test publishes numbered ``JointState`` messages
(message i is stamped i ms) from a fresh rclpy Context, calls the services over DDS
(``std_srvs/Trigger``) and follows the recorder's counters on ``/diagnostics``. The bag
must then read back with this package's reader and with rosbags, file by file as split.
"""
from __future__ import annotations

import json
import signal
from pathlib import Path

import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from scara_ident_ros.bag import open_bag

import rostest  # test/nodes/rostest.py

pytestmark = pytest.mark.ros

RECORDER = 'scara_ident_ros.nodes.recorder'
NODE = '/recorder'
JOINT_STATES = '/joint_states'
STATUS_NAME = '/recorder: recording'
BATCH = 300  # messages published between two service calls
DISCOVERY_TIMEOUT = 60.0  # s, the machine is shared (a node took 19 s to refuse a bad
# parameter and exit at load 22)
COUNT_TIMEOUT = 30.0  # s for the recorder to report a count
OK, WARN = b'\x00', b'\x01'  # DiagnosticStatus levels


def numbered(i: int) -> JointState:
    msg = JointState(name=['joint1'], position=[float(i)], velocity=[0.0], effort=[0.0])
    msg.header.stamp.sec, ms = divmod(i, 1000)
    msg.header.stamp.nanosec = ms * 1_000_000
    return msg


def index(msg: JointState) -> int:
    return int(msg.header.stamp.sec) * 1000 + int(msg.header.stamp.nanosec) // 1_000_000


def anyreader_indices(bag: Path) -> list[int]:
    with AnyReader([bag]) as reader:
        return [index(reader.deserialize(raw, c.msgtype)) for c, _, raw in reader.messages()]


@pytest.mark.slow
def test_split_pause_resume_and_diagnostics(tmp_path: Path,
                                            listener: rostest.Listener) -> None:
    bag, stats = tmp_path / 'bag', tmp_path / 'stats.json'
    publisher = listener.node.create_publisher(JointState, JOINT_STATES, rostest.reliable())
    statuses: list[DiagnosticStatus] = []
    listener.node.create_subscription(
        DiagnosticArray, '/diagnostics',
        lambda msg: statuses.extend(s for s in msg.status if s.name == STATUS_NAME),
        rostest.reliable(100))
    sent = 0

    def publish_batch() -> None:
        nonlocal sent
        for i in range(sent, sent + BATCH):
            publisher.publish(numbered(i))
        sent += BATCH

    def received(count: int) -> DiagnosticStatus:
        """The first status reporting ``count`` messages received."""
        def found() -> DiagnosticStatus | None:
            return next((s for s in statuses if {kv.key: kv.value for kv in s.values}
                         .get('received') == str(count)), None)
        assert listener.spin_until(lambda: found() is not None, COUNT_TIMEOUT), \
            [s.values for s in statuses[-3:]]
        status = found()
        assert status is not None
        return status

    def call(service: str) -> Trigger.Response:
        return listener.call(Trigger, f'{NODE}/{service}', Trigger.Request())

    args = ['-p', f'output:={bag}', '-p', 'discovery_period:=0.1', '-p', f'stats_file:={stats}']
    with rostest.NodeProcess(RECORDER, args) as recorder:
        assert listener.spin_until(
            lambda: publisher.get_subscription_count() >= 1 or recorder.exited(),
            DISCOVERY_TIMEOUT), 'the recorder did not subscribe'
        assert not recorder.exited(), recorder.stderr_so_far()
        listener.spin_until(lambda: False, 1.0)  # the recorder's side of the match

        publish_batch()  # 0-299 into bag_0.mcap
        first = received(BATCH)
        assert first.level == OK and first.hardware_id == ''
        assert listener.set_parameters(NODE, max_bag_duration=3600.0)[0].successful
        fixed = listener.set_parameters(NODE, compression='zstd')[0]
        assert not fixed.successful and 'read-only' in fixed.reason
        split = call('split')
        assert split.success and split.message == 'now writing bag_1.mcap'

        publish_batch()  # 300-599 into bag_1.mcap
        received(2 * BATCH)
        pause = call('pause')
        assert pause.success and pause.message == 'paused'
        assert call('pause').message == 'already paused'

        publish_batch()  # 600-899: not written
        paused = received(3 * BATCH)
        values = {kv.key: kv.value for kv in paused.values}
        assert paused.level == WARN and 'paused' in paused.message
        assert values['not written (paused)'] == str(BATCH)
        assert values['written'] == str(2 * BATCH) and values['files'] == '2'
        assert call('resume').success

        publish_batch()  # 900-1199 into bag_1.mcap
        resumed = received(4 * BATCH)
        assert resumed.level == OK
        output = recorder.stop(signal.SIGINT)
    assert output.returncode == 0, output.stderr

    counters = json.loads(stats.read_text())
    assert counters['received'] == 4 * BATCH
    assert counters['written'] == 3 * BATCH and counters['paused'] == BATCH
    assert counters['files'] == ['bag_0.mcap', 'bag_1.mcap']
    expected = [*range(2 * BATCH), *range(3 * BATCH, 4 * BATCH)]
    with open_bag(bag) as source:
        ours = [index(deserialize_message(m.data, JointState)) for m in source.messages()]
    assert ours == expected
    assert anyreader_indices(bag) == expected
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert [f['message_count'] for f in info['files']] == [BATCH, 2 * BATCH]
    assert info['relative_file_paths'] == ['bag_0.mcap', 'bag_1.mcap']
