"""The player node (and ``scara-ident play``) in its own process, heard by a test listener.

The bags are written with :class:`~scara_ident_ros.bag.BagWriter` from messages
serialized by rclpy: JointState number i has i in ``header.stamp`` (i ms). The listener
subscribes raw, so what arrives can be compared byte for byte with what was recorded.
Bags of other writers (a sqlite3 rosbag2 bag of rosbags, a bare ``.mcap`` of
mcap-ros2-support, from ``test/bag/bag_files.py``) are compared message by message.
"""
from __future__ import annotations

import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from rosbags.typesys import Stores, get_typestore

pytestmark = [pytest.mark.ros, pytest.mark.usefixtures('domain')]  # before the listener

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / 'bag'))  # bag_files: bags of rosbags, mcap-ros2-support

PLAYER = 'scara_ident_ros.nodes.player'
JOINT_STATES = '/joint_states'
MSE = '/ffmw/identification_mse'
START_NS = 1_700_000_000_000_000_000
RUN_TIMEOUT = 60.0  # s for a player run to end by itself (the machine is shared)


def joint_state(i: int) -> bytes:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    msg = JointState()
    msg.header.stamp.sec, ms = divmod(i, 1000)
    msg.header.stamp.nanosec = ms * 1_000_000
    msg.name = ['joint1', 'joint2']
    msg.position = [float(i), -float(i)]
    return bytes(serialize_message(msg))


def float_array(value: float) -> bytes:
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64MultiArray

    return bytes(serialize_message(Float64MultiArray(data=[value])))


def make_bag(path: Path, count: int, period_ns: int, *, mse_every: int = 0) -> list[bytes]:
    """A bag with ``count`` joint states ``period_ns`` apart; return their bytes as the
    player publishes them.

    They are recorded as rclpy serializes them, with slack bytes after the empty
    ``effort`` (as earlier versions of the identifier recorded its predictions); the player
    publishes each at its exact CDR length, which is what is returned.
    """
    from scara_ident_ros.bag import BagWriter
    from scara_ident_ros.bag.exact_cdr import exact_joint_state

    payloads = [joint_state(i) for i in range(count)]
    with BagWriter(path) as writer:
        js = writer.add_connection(JOINT_STATES, 'sensor_msgs/msg/JointState')
        mse = writer.add_connection(MSE, 'std_msgs/msg/Float64MultiArray') if mse_every else None
        for i, payload in enumerate(payloads):
            writer.write(js.id, START_NS + i * period_ns, payload)
            if mse is not None and i % mse_every == 0:
                writer.write(mse.id, START_NS + i * period_ns + period_ns // 2,
                             float_array(float(i)))
    exact = [exact_joint_state(payload) for payload in payloads]
    assert all(len(e) < len(p) for e, p in zip(exact, payloads))  # slack recorded, then cut
    return exact


def subscribe_raw(listener: Any, msg_type: Any, topic: str) -> list[tuple[float, bytes]]:
    """Raw subscription of the listener; (arrival time, bytes) are appended to the list."""
    from rostest import reliable

    received: list[tuple[float, bytes]] = []
    listener.node.create_subscription(
        msg_type, topic, lambda data: received.append((time.monotonic(), data)),
        reliable(), raw=True)
    return received


def play(*ros_args: str) -> Any:
    """The player in its own process; it waits up to 15 s for the listener to match
    (returning as soon as it does): the first discovery in a process can take one
    Fast DDS announcement period, 3 s, and the machine is shared."""
    from rostest import NodeProcess

    return NodeProcess(PLAYER, [*ros_args, '-p', 'wait_timeout:=15.0'])


def spin_until_exit(listener: Any, player: Any, timeout: float = RUN_TIMEOUT) -> Any:
    """Spin the listener until the player exits by itself; return its output."""
    assert listener.spin_until(player.exited, timeout), player.stderr_so_far()
    listener.spin_until(lambda: False, 0.3)  # the last messages in flight
    return player.wait(timeout=5)


# -- tests -------------------------------------------------------------------------------


@pytest.mark.parametrize('rate', [1.0, 2.0])
def test_plays_every_message_at_the_recorded_pace_then_exits(
        tmp_path: Path, listener: Any, rate: float) -> None:
    from sensor_msgs.msg import JointState

    payloads = make_bag(tmp_path / 'bag', 21, 50_000_000)  # 1.0 s of recording
    received = subscribe_raw(listener, JointState, JOINT_STATES)
    with play('-p', f'bag:={tmp_path / "bag"}', '-p', f'rate:={rate}') as player:
        output = spin_until_exit(listener, player)
    assert output.returncode == 0, output.stderr
    assert [data for _, data in received] == payloads  # all, first one included, in order
    store = get_typestore(Stores.ROS2_JAZZY)  # which refuses the slack the bag holds
    assert [store.deserialize_cdr(data, 'sensor_msgs/msg/JointState').position[0]
            for _, data in received] == list(range(21))
    span = received[-1][0] - received[0][0]
    assert 0.8 / rate < span < 1.0 / rate + 0.4, span
    gaps = [b[0] - a[0] for a, b in zip(received, received[1:])]
    # spaced out, not bunched (the median: on a loaded machine the listener itself may be
    # late and take two at once, 21 µs apart)
    assert statistics.median(gaps) > 0.025 / rate, gaps
    assert 'played 21 messages' in output.stderr


def test_rate_zero_plays_as_fast_as_possible(tmp_path: Path, listener: Any) -> None:
    from sensor_msgs.msg import JointState

    payloads = make_bag(tmp_path / 'bag', 500, 10_000_000)  # 5 s of recording
    received = subscribe_raw(listener, JointState, JOINT_STATES)
    with play('-p', f'bag:={tmp_path / "bag"}', '-p', 'rate:=0.0') as player:
        output = spin_until_exit(listener, player)
    assert output.returncode == 0, output.stderr
    assert [data for _, data in received] == payloads, output.stderr
    assert received[-1][0] - received[0][0] < 2.0


def test_loop_starts_over_until_stopped(tmp_path: Path, listener: Any) -> None:
    from sensor_msgs.msg import JointState

    payloads = make_bag(tmp_path / 'bag', 5, 20_000_000)
    received = subscribe_raw(listener, JointState, JOINT_STATES)
    with play('-p', f'bag:={tmp_path / "bag"}', '-p', 'loop:=true') as player:
        assert listener.spin_until(lambda: len(received) >= 17, RUN_TIMEOUT), \
            player.stderr_so_far()
        assert not player.exited()
        output = player.stop(signal.SIGINT)
    assert output.returncode == 0, output.stderr
    assert [data for _, data in received[:15]] == payloads * 3
    assert 'passes' in output.stderr


def test_topics_and_remap(tmp_path: Path, listener: Any) -> None:
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    payloads = make_bag(tmp_path / 'bag', 30, 5_000_000, mse_every=10)
    remapped = subscribe_raw(listener, JointState, '/replay/joint_states')
    original = subscribe_raw(listener, JointState, JOINT_STATES)
    mse = subscribe_raw(listener, Float64MultiArray, MSE)
    with play('-p', f'bag:={tmp_path / "bag"}', '-p', f'topics:=[{JOINT_STATES}]',
              '-p', f"remap:=['{JOINT_STATES}:=/replay/joint_states']") as player:
        output = spin_until_exit(listener, player)
    assert output.returncode == 0, output.stderr
    assert [data for _, data in remapped] == payloads
    assert original == [] and mse == []


def test_clock_publishes_the_recorded_time(tmp_path: Path, listener: Any) -> None:
    from rosgraph_msgs.msg import Clock

    from sensor_msgs.msg import JointState

    make_bag(tmp_path / 'bag', 11, 100_000_000)  # 1.0 s
    clocks = listener.subscribe(Clock, '/clock')
    # the bag's topic too: the player waits (wait_timeout, 15 s) for a subscriber on each
    listener.subscribe(JointState, JOINT_STATES)
    with play('-p', f'bag:={tmp_path / "bag"}', '-p', 'clock:=true',
              '-p', 'clock_rate:=50.0') as player:
        output = spin_until_exit(listener, player)
    assert output.returncode == 0, output.stderr
    times = [c.clock.sec * 1_000_000_000 + c.clock.nanosec for c in clocks]
    assert times == sorted(times)
    assert START_NS <= times[0] and times[-1] == START_NS + 1_000_000_000
    assert 30 <= len(times) <= 80  # ~50 Hz over 1 s


def foreign_bag(tmp_path: Path, kind: str, states: Any) -> Path:
    """``states`` in a bag this project did not write: a sqlite3 rosbag2 bag written with
    rosbags (``'sqlite3'``) or a bare ``.mcap`` written with mcap-ros2-support (``'mcap'``)."""
    from bag_files import write_bare_mcap, write_robot_bag

    if kind == 'sqlite3':
        bag = write_robot_bag(tmp_path / 'bag', states, storage='sqlite3')
        assert list(bag.glob('*.db3')), list(bag.iterdir())
        return bag
    return write_bare_mcap(tmp_path / 'bag.mcap', states)


@pytest.mark.parametrize('kind', ['sqlite3', 'mcap'])
def test_plays_bags_written_by_other_tools(tmp_path: Path, listener: Any, kind: str) -> None:
    import numpy as np
    from bag_files import robot
    from sensor_msgs.msg import JointState

    states = robot(2, 200, seed=3)  # 2 joints, 0.2 s at 1 kHz
    bag = foreign_bag(tmp_path, kind, states)
    received = listener.subscribe(JointState, JOINT_STATES)
    with play('-p', f'bag:={bag}') as player:
        output = spin_until_exit(listener, player)
    assert output.returncode == 0, output.stderr
    assert len(received) == len(states.stamp_ns), output.stderr  # every one, the first too
    stamps = [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in received]
    assert stamps == states.stamp_ns.tolist()  # in the recorded order
    assert all(tuple(m.name) == states.names for m in received)
    for field in ('position', 'velocity', 'effort'):
        values = np.array([getattr(m, field) for m in received])
        assert np.array_equal(values, getattr(states, field)), field  # bit for bit
    assert f'played {len(states.stamp_ns)} messages' in output.stderr


@pytest.mark.parametrize('kind', ['missing', 'truncated', 'garbage', 'no_bag', 'no_topic'])
def test_bad_bag_gives_one_line_and_exit_2(tmp_path: Path, domain: int, kind: str) -> None:
    bag = tmp_path / 'bag'
    args = ['-p', f'bag:={bag}']
    expected = {'missing': 'bag: does not exist', 'truncated': 'truncated MCAP file',
                'garbage': 'not an MCAP file', 'no_bag': "parameter 'bag' is required",
                'no_topic': 'no topic matches'}[kind]
    if kind == 'truncated':
        make_bag(bag, 3000, 1_000_000)
        file = next(bag.glob('*.mcap'))
        file.write_bytes(file.read_bytes()[:20_000])
    elif kind == 'garbage':
        bag = tmp_path / 'bag.mcap'
        bag.write_bytes(b'garbage!' * 64)
        args = ['-p', f'bag:={bag}']
    elif kind == 'no_bag':
        args = []
    elif kind == 'no_topic':
        make_bag(bag, 3, 1_000_000)
        args.extend(['-p', 'topics:=[/nothing]'])
    with play(*args) as player:
        output = player.wait(timeout=30)
    assert output.returncode == 2
    lines = output.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('player: error:'), output.stderr
    assert expected in lines[0]


def scara_ident(*args: str) -> subprocess.Popen[str]:
    code = 'import sys; from scara_ident_ros.cli import main; sys.exit(main(sys.argv[1:]))'
    return subprocess.Popen([sys.executable, '-c', code, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def test_scara_ident_play(tmp_path: Path, listener: Any) -> None:
    from sensor_msgs.msg import JointState

    payloads = make_bag(tmp_path / 'bag', 200, 1_000_000, mse_every=50)
    received = subscribe_raw(listener, JointState, '/replay')
    process = scara_ident('play', str(tmp_path / 'bag'), '--rate', 'max', '--topics',
                          JOINT_STATES, '--remap', f'{JOINT_STATES}:=/replay')
    try:
        assert listener.spin_until(lambda: process.poll() is not None, RUN_TIMEOUT)
        listener.spin_until(lambda: False, 0.3)
        _, err = process.communicate(timeout=5)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, err
    assert [data for _, data in received] == payloads, err


@pytest.mark.parametrize('args, expected', [
    (['/no/such/bag'], '/no/such/bag: does not exist'),
    (['BAG', '--rate', '-2'], 'rate must be a number > 0'),
    (['BAG', '--remap', 'nonsense'], "remap must look like 'old:=new'"),
])
def test_scara_ident_play_errors(tmp_path: Path, domain: int, args: list[str],
                                 expected: str) -> None:
    make_bag(tmp_path / 'bag', 3, 1_000_000)
    args = [str(tmp_path / 'bag') if a == 'BAG' else a for a in args]
    process = scara_ident('play', *args)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('scara-ident play: error:'), err
    assert expected in lines[0]



def test_plays_a_csv_export_as_joint_states_at_its_own_timing(tmp_path: Path,
                                                              listener: Any) -> None:
    """A /joint_states CSV export (three files, uneven stamps 7.7-12.3 ms, as TIAGo's):
    one JointState per row, stamped as the row, spaced as the stamps."""
    import numpy as np
    from sensor_msgs.msg import JointState

    rng = np.random.default_rng(0)
    t = np.concatenate(([0.0], np.cumsum(rng.uniform(7.7e-3, 12.3e-3, 59))))  # 0.6 s
    folder = tmp_path / 'export'
    folder.mkdir()
    for k, field in enumerate(('position', 'velocity', 'effort')):
        values = np.column_stack([t, np.sin(t + k), np.cos(t + k)])
        np.savetxt(folder / f'arm_{field}.csv', values, delimiter=',', comments='',
                   header=f't,- a_{field},- b_{field}', fmt='%.17g')
    from rclpy.serialization import deserialize_message

    raw = subscribe_raw(listener, JointState, JOINT_STATES)
    with play('-p', f'bag:={folder / "arm_effort.csv"}') as player:
        output = spin_until_exit(listener, player)
    assert output.returncode == 0, output.stderr
    assert len(raw) == 60, output.stderr
    received = [deserialize_message(data, JointState) for _, data in raw]
    arrivals = [arrived for arrived, _ in raw]
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in received]
    assert stamps == np.round(t * 1e9).astype(np.int64).tolist()
    assert list(received[0].name) == ['a', 'b']
    np.testing.assert_allclose(received[30].velocity, [np.sin(t[30] + 1), np.cos(t[30] + 1)])
    span = arrivals[-1] - arrivals[0]
    assert 0.5 < span < t[-1] + 0.4, span
