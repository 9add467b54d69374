"""The recorder node in its own process, fed by a 1 kHz publisher process.

Run as a script (``python test_recorder.py publish --count K ...``) this module is that
publisher: JointState number i on ``/joint_states`` carries i in ``header.stamp``
(i ms) and in its values, so a bag can be checked message by message; every
``--mse-every``-th step a Float64MultiArray ``[i]`` follows on
``/ffmw/identification_mse`` half a period later.

Each test gets its own ROS domain (the ``domain`` fixture of conftest.py, claimed by a
lock); children are always killed on the way out.
"""
from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

pytestmark = pytest.mark.ros

RECORDER = 'scara_ident_ros.nodes.recorder'
JOINT_STATES = '/joint_states'
MSE = '/ffmw/identification_mse'
NAMES = ['joint1', 'joint2', 'joint3', 'joint4']
PUBLISH_TIMEOUT = 90.0  # s for a publisher run, matching included (the machine is shared)

# -- the publisher process ---------------------------------------------------------------


def publish_main(argv: list[str]) -> int:
    """Publish ``--count`` joint states at ``--rate`` once every topic has a subscriber."""
    parser = argparse.ArgumentParser()
    parser.add_argument('--count', type=int, required=True)
    parser.add_argument('--rate', type=float, default=1000.0)
    parser.add_argument('--mse-every', type=int, default=0)
    parser.add_argument('--extra', action='store_true',
                        help='also /chatter (std_msgs/String) and the hidden /_hidden')
    parser.add_argument('--wait-chatter', action='store_true',
                        help='wait for a /chatter subscriber too before publishing')
    args = parser.parse_args(argv)

    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, String

    rclpy.init()
    node = rclpy.create_node('test_publisher')
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    joint_states = node.create_publisher(JointState, JOINT_STATES, qos)
    publishers = [joint_states]
    mse = node.create_publisher(Float64MultiArray, MSE, qos) if args.mse_every else None
    if mse is not None:
        publishers.append(mse)
    extra = []
    if args.extra:
        extra = [node.create_publisher(String, '/chatter', qos),
                 node.create_publisher(String, '/_hidden', qos)]
        if args.wait_chatter:
            publishers.append(extra[0])
    deadline = time.monotonic() + PUBLISH_TIMEOUT / 2
    while any(p.get_subscription_count() == 0 for p in publishers):
        if time.monotonic() > deadline:
            print('no subscriber', flush=True)
            return 3
        time.sleep(0.02)
    time.sleep(0.3)  # the subscriber's side of the match
    msg = JointState()
    msg.name = NAMES
    period = 1.0 / args.rate
    start = time.perf_counter()
    for i in range(args.count):
        _sleep_until(start + i * period)
        msg.header.stamp.sec, ms = divmod(i, 1000)
        msg.header.stamp.nanosec = ms * 1_000_000
        msg.position = [float(i), -float(i), 0.5 * i, 2.0 * i]
        msg.velocity = [1.0, 2.0, 3.0, 4.0]
        msg.effort = [float(i % 7)] * 4
        joint_states.publish(msg)
        if mse is not None and i % args.mse_every == 0:
            _sleep_until(start + (i + 0.5) * period)
            mse.publish(Float64MultiArray(data=[float(i)]))
        if extra and i % 100 == 0:
            for publisher in extra:
                publisher.publish(String(data=f'step {i}'))
    for publisher in publishers + extra:
        publisher.wait_for_all_acked(Duration(seconds=20))
    print('done', flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0


def _sleep_until(target: float) -> None:
    left = target - time.perf_counter()
    if left > 0:
        time.sleep(left)


def run_publisher(*args: str, timeout: float = PUBLISH_TIMEOUT) -> None:
    """Run the publisher process to its end (it is killed on timeout)."""
    result = subprocess.run([sys.executable, str(Path(__file__)), 'publish', *args],
                            capture_output=True, text=True, timeout=timeout, check=False)
    assert result.returncode == 0 and 'done' in result.stdout, result.stdout + result.stderr


def start_publisher(*args: str) -> subprocess.Popen[str]:
    """Start the publisher process (the caller kills it)."""
    return subprocess.Popen([sys.executable, str(Path(__file__)), 'publish', *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


# -- reading bags back -------------------------------------------------------------------


def anyreader_messages(bag: Path) -> dict[str, list[Any]]:
    """Deserialized messages per topic, read with rosbags' AnyReader."""
    from rosbags.highlevel import AnyReader

    topics: dict[str, list[Any]] = {}
    with AnyReader([bag]) as reader:
        for connection, _, raw in reader.messages():
            topics.setdefault(connection.topic, []).append(
                reader.deserialize(raw, connection.msgtype))
    return topics


def mcap_messages(bag: Path) -> dict[str, list[Any]]:
    """Decoded messages per topic, read file by file with mcap + mcap_ros2 alone."""
    import yaml
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    topics: dict[str, list[Any]] = {}
    for name in info['relative_file_paths']:
        with (bag / name).open('rb') as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            for _, channel, _, decoded in reader.iter_decoded_messages(log_time_order=True):
                topics.setdefault(channel.topic, []).append(decoded)
    return topics


def stamp_index(msg: Any) -> int:
    """The publisher's message number i, from header.stamp (i ms)."""
    return int(msg.header.stamp.sec) * 1000 + int(msg.header.stamp.nanosec) // 1_000_000


def recorder_args(bag: Path, *extra: str) -> list[str]:
    return ['-p', f'output:={bag}', '-p', 'discovery_period:=0.2', *extra]


# -- tests -------------------------------------------------------------------------------


def test_records_everything_in_order_and_closes_the_bag_on_sigterm(
        tmp_path: Path, domain: int) -> None:
    from rostest import NodeProcess

    bag, stats = tmp_path / 'bag', tmp_path / 'stats.json'
    count = 2000
    with NodeProcess(RECORDER, recorder_args(bag, '-p', f'stats_file:={stats}',
                                             '-p', 'compression:=zstd')) as recorder:
        recorder.wait_for_stderr('recording', timeout=30)
        run_publisher('--count', str(count), '--mse-every', '10')
        output = recorder.stop(signal.SIGTERM)
    assert output.returncode == 0, output.stderr
    assert f'{count + count // 10} of {count + count // 10} received messages written' \
        in output.stderr

    for read in (anyreader_messages, mcap_messages):  # two independent readers
        topics = read(bag)
        assert sorted(topics) == [MSE, JOINT_STATES]
        assert [stamp_index(m) for m in topics[JOINT_STATES]] == list(range(count))
        assert list(topics[JOINT_STATES][1234].position) == [1234.0, -1234.0, 617.0, 2468.0]
        assert [m.data[0] for m in topics[MSE]] == [float(i) for i in range(0, count, 10)]

    import yaml
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['message_count'] == count + count // 10
    by_topic = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert by_topic[JOINT_STATES]['message_count'] == count
    assert by_topic[MSE]['message_count'] == count // 10
    offered = by_topic[JOINT_STATES]['topic_metadata']['offered_qos_profiles']
    assert len(offered) == 1 and offered[0]['reliability'] == 'reliable'
    assert offered[0]['durability'] == 'volatile'
    assert by_topic[JOINT_STATES]['topic_metadata']['type_description_hash'].startswith(
        'RIHS01_')
    counters = json.loads(stats.read_text())
    assert counters['received'] == counters['written'] == count + count // 10
    assert counters['topics'] == {MSE: count // 10, JOINT_STATES: count}


def test_sigkill_leaves_a_bag_that_recover_bag_makes_readable(tmp_path: Path,
                                                              domain: int) -> None:
    from rostest import NodeProcess

    from scara_ident_ros.bag import BagError, open_bag, recover_bag

    bag = tmp_path / 'bag'
    args = recorder_args(bag, '-p', 'max_chunk_duration:=0.2', '-p', 'max_chunk_size:=16384')
    with NodeProcess(RECORDER, args) as recorder:
        recorder.wait_for_stderr('recording', timeout=30)
        publisher = start_publisher('--count', '20000')
        try:
            file = bag / 'bag_0.mcap'
            deadline = time.monotonic() + PUBLISH_TIMEOUT
            while not file.is_file() or file.stat().st_size < 150_000:
                assert time.monotonic() < deadline, recorder.stderr_so_far()
                assert publisher.poll() is None, publisher.communicate()
                time.sleep(0.05)
            on_disk = file.stat().st_size
            recorder.process.kill()  # SIGKILL: no close, no metadata.yaml
            recorder.process.wait()
        finally:
            publisher.kill()
            publisher.wait()
    with pytest.raises(BagError, match='recover it'):
        open_bag(bag)
    report = recover_bag(bag)
    assert report.files[0].rewritten
    topics = anyreader_messages(bag)
    indices = [stamp_index(m) for m in topics[JOINT_STATES]]
    assert indices == list(range(len(indices)))  # a gap-free prefix, in order
    per_message = (bag / 'bag_0.mcap').stat().st_size / len(indices)
    assert len(indices) >= on_disk / per_message * 0.8  # what was on disk at the kill
    with open_bag(bag) as source:
        assert source.topics[JOINT_STATES].count == len(indices)


def test_split_by_size_reads_back_as_one_bag(tmp_path: Path, domain: int) -> None:
    from rostest import NodeProcess

    bag = tmp_path / 'bag'
    count = 2000
    args = recorder_args(bag, '-p', 'max_bag_size:=60000', '-p', 'max_chunk_size:=8192')
    with NodeProcess(RECORDER, args) as recorder:
        recorder.wait_for_stderr('recording', timeout=30)
        run_publisher('--count', str(count))
        output = recorder.stop(signal.SIGINT)
    assert output.returncode == 0, output.stderr
    files = sorted(bag.glob('*.mcap'))
    assert len(files) >= 4
    assert {f.name for f in files} == {f'bag_{i}.mcap' for i in range(len(files))}
    topics = anyreader_messages(bag)
    assert [stamp_index(m) for m in topics[JOINT_STATES]] == list(range(count))
    assert [stamp_index(m) for m in mcap_messages(bag)[JOINT_STATES]] == list(range(count))


def test_all_records_every_visible_topic(tmp_path: Path, domain: int) -> None:
    from rostest import NodeProcess

    bag = tmp_path / 'bag'
    with NodeProcess(RECORDER, recorder_args(bag, '-p', 'all:=true')) as recorder:
        recorder.wait_for_stderr('recording', timeout=30)
        run_publisher('--count', '300', '--extra', '--wait-chatter')
        output = recorder.stop(signal.SIGINT)
    assert output.returncode == 0, output.stderr
    topics = anyreader_messages(bag)
    assert [m.data for m in topics['/chatter']] == ['step 0', 'step 100', 'step 200']
    assert len(topics[JOINT_STATES]) == 300
    assert '/_hidden' not in topics


def test_default_topics_skip_others(tmp_path: Path, domain: int) -> None:
    from rostest import NodeProcess

    bag = tmp_path / 'bag'
    with NodeProcess(RECORDER, recorder_args(bag)) as recorder:
        recorder.wait_for_stderr('recording', timeout=30)
        run_publisher('--count', '200', '--mse-every', '50', '--extra')
        output = recorder.stop(signal.SIGINT)
    assert output.returncode == 0, output.stderr
    assert sorted(anyreader_messages(bag)) == [MSE, JOINT_STATES]


@pytest.mark.parametrize('args, message', [
    (['-p', 'compression:=bz2'], "parameter 'compression' must be one of none, zstd, lz4"),
    (['-p', 'topics:=[\'\']'], 'empty topic name or pattern'),
    (['-p', 'max_bag_size:=-1'], "parameter 'max_bag_size'"),
])
def test_bad_parameters_give_one_line_and_exit_2(tmp_path: Path, domain: int,
                                                 args: list[str], message: str) -> None:
    from rostest import NodeProcess

    with NodeProcess(RECORDER, ['-p', f'output:={tmp_path / "bag"}', *args]) as recorder:
        output = recorder.wait(timeout=30)
    assert output.returncode == 2
    lines = output.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('recorder: error:'), output.stderr
    assert message in lines[0]
    assert not (tmp_path / 'bag').exists()


def test_refuses_to_overwrite_an_existing_bag(tmp_path: Path, domain: int) -> None:
    from rostest import NodeProcess

    (tmp_path / 'bag').mkdir()
    (tmp_path / 'bag' / 'keep.txt').write_text('precious')
    with NodeProcess(RECORDER, ['-p', f'output:={tmp_path / "bag"}']) as recorder:
        output = recorder.wait(timeout=30)
    assert output.returncode == 2
    assert output.stderr.strip() == (f'recorder: error: {tmp_path / "bag"} exists already, '
                                     'not overwriting')
    assert (tmp_path / 'bag' / 'keep.txt').read_text() == 'precious'


if __name__ == '__main__':
    if sys.argv[1:2] == ['publish']:
        sys.exit(publish_main(sys.argv[2:]))
    sys.exit(f'usage: {sys.argv[0]} publish --count K [--rate HZ] [--mse-every N] [--extra]')
