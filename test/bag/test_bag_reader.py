"""open_bag and read_joint_states on bags written by other tools, and every error case."""
from __future__ import annotations

import shlex
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bag_files import (FLOAT64_ARRAY, JOINT_STATE, float_array, joint_state,  # noqa: E402
                       robot, robot_messages, write_bare_mcap, write_robot_bag,
                       write_rosbags_bag)

from scara_ident_ros.bag import BagError, open_bag, read_joint_states  # noqa: E402


def assert_same_states(series, states, order=None) -> None:  # type: ignore[no-untyped-def]
    perm = list(range(len(states.names))) if order is None else list(order)
    assert series.names == tuple(states.names[j] for j in perm)
    np.testing.assert_array_equal(series.stamp_ns, states.stamp_ns)
    assert series.stamp_ns.dtype == np.int64
    for field in ('position', 'velocity', 'effort'):
        got = getattr(series, field)
        assert got.shape == (len(states.stamp_ns), len(states.names))
        np.testing.assert_array_equal(got, getattr(states, field)[:, perm])


@pytest.mark.parametrize('n_joints', [2, 6])
def test_sqlite3_bag_written_by_rosbags(tmp_path: Path, n_joints: int) -> None:
    states = robot(n_joints, 300, seed=n_joints)
    bag = write_robot_bag(tmp_path / 'bag', states, storage='sqlite3')
    series = read_joint_states(bag)
    assert series.topic == '/joint_states'
    assert_same_states(series, states)
    np.testing.assert_array_equal(series.log_time_ns, states.stamp_ns)


@pytest.mark.parametrize('n_joints', [2, 6])
def test_bare_mcap_written_by_mcap_ros2_support(tmp_path: Path, n_joints: int) -> None:
    states = robot(n_joints, 250, seed=10 + n_joints)
    series = read_joint_states(write_bare_mcap(tmp_path / 'run.mcap', states))
    assert_same_states(series, states)


@pytest.mark.parametrize('n_joints', [2, 6])
def test_rosbag2_mcap_bag_maps_joints_by_name(tmp_path: Path, n_joints: int) -> None:
    states = robot(n_joints, 200, seed=20 + n_joints)
    order = list(reversed(range(n_joints)))
    bag = write_robot_bag(tmp_path / 'bag', states, storage='mcap', order=order)
    # Joint order of the first message by default...
    assert_same_states(read_joint_states(bag), states, order=order)
    # ... or the order asked for, whatever order the messages use.
    assert_same_states(read_joint_states(bag, joints=states.names), states)


def test_messages_mixing_joint_orders_land_in_the_same_columns(tmp_path: Path) -> None:
    states = robot(3, 40)
    forward = robot_messages(states)
    backward = robot_messages(states, order=[2, 1, 0])
    mixed = [forward[i] if i % 2 else backward[i] for i in range(40)]
    bag = write_rosbags_bag(tmp_path / 'bag', {'/joint_states': (
        JOINT_STATE, list(zip(states.stamp_ns.tolist(), mixed)))})
    assert_same_states(read_joint_states(bag, joints=states.names), states)


def test_missing_values_are_nan_and_foreign_messages_are_skipped(tmp_path: Path) -> None:
    t0 = 1_000_000_000
    messages = [
        (t0, joint_state(t0, ['a', 'b'], [1.0, 2.0], [3.0, 4.0], [5.0, 6.0])),
        (t0 + 1, joint_state(t0 + 1, ['gripper'], [0.5])),  # another publisher: skipped
        (t0 + 2, joint_state(t0 + 2, ['b', 'a'], [20.0, 10.0])),  # no velocity, no effort
        (t0 + 3, joint_state(t0 + 3, ['b'], [200.0], [400.0])),  # only joint b
        (t0 + 4, joint_state(t0 + 4, ['a', 'b'], [1.0], [2.0, 3.0])),  # bad length: NaN
    ]
    bag = write_rosbags_bag(tmp_path / 'bag', {'/joint_states': (JOINT_STATE, messages)})
    series = read_joint_states(bag)
    assert series.names == ('a', 'b')
    np.testing.assert_array_equal(series.stamp_ns, [t0, t0 + 2, t0 + 3, t0 + 4])
    nan = np.nan
    np.testing.assert_array_equal(series.position, [[1, 2], [10, 20], [nan, 200], [nan, nan]])
    np.testing.assert_array_equal(series.velocity, [[3, 4], [nan, nan], [nan, 400], [2, 3]])
    np.testing.assert_array_equal(series.effort, [[5, 6], [nan, nan], [nan, nan],
                                                  [nan, nan]])


def test_big_endian_messages_are_read_too(tmp_path: Path) -> None:
    from bag_files import STORE

    states = robot(2, 6)
    messages = []
    for i, raw in enumerate(robot_messages(states)):
        if i % 2:  # re-encode every other message big-endian
            msg = STORE.deserialize_cdr(raw, JOINT_STATE)
            raw = bytes(STORE.serialize_cdr(msg, JOINT_STATE, little_endian=False))
        messages.append((int(states.stamp_ns[i]), raw))
    bag = write_rosbags_bag(tmp_path / 'bag', {'/joint_states': (JOINT_STATE, messages)})
    assert_same_states(read_joint_states(bag), states)


def test_undecodable_joint_state_is_an_error(tmp_path: Path) -> None:
    good = joint_state(1, ['a'], [1.0])
    bag = write_rosbags_bag(tmp_path / 'bag', {'/joint_states': (JOINT_STATE, [
        (1, good), (2, good[:20])])})
    with pytest.raises(BagError, match='JointState message 1 cannot be decoded'):
        read_joint_states(bag)


def test_joint_states_is_preferred_among_several_joint_state_topics(tmp_path: Path) -> None:
    states = robot(2, 10)
    messages = list(zip(states.stamp_ns.tolist(), robot_messages(states)))
    bag = write_rosbags_bag(tmp_path / 'bag', {
        '/ffmw/identified_torque': (JOINT_STATE, messages[:5]),
        '/joint_states': (JOINT_STATE, messages),
        '/ffmw/identification_mse': (FLOAT64_ARRAY, [(1, float_array([1.0]))])})
    assert read_joint_states(bag).topic == '/joint_states'
    assert len(read_joint_states(bag, topic='/ffmw/identified_torque')) == 5


def test_open_bag_lists_topics_and_yields_messages_in_log_time_order(tmp_path: Path) -> None:
    js = [(t, joint_state(t, ['a'], [float(t)])) for t in (10, 30, 50)]
    mse = [(t, float_array([float(t)])) for t in (20, 40)]
    bag = write_rosbags_bag(tmp_path / 'bag', {'/joint_states': (JOINT_STATE, js),
                                               '/mse': (FLOAT64_ARRAY, mse)}, storage='mcap')
    with open_bag(bag) as source:
        assert source.topics == {'/joint_states': (JOINT_STATE, 3), '/mse': (FLOAT64_ARRAY, 2)}
        assert source.message_count == 5
        assert (source.start_ns, source.end_ns) == (10, 50)
        got = [(m.topic, m.msgtype, m.log_time_ns, m.data) for m in source.messages()]
        assert [g[2] for g in got] == [10, 20, 30, 40, 50]
        assert got[1] == ('/mse', FLOAT64_ARRAY, 20, mse[0][1])
        assert [m.log_time_ns for m in source.messages(['/mse'])] == [20, 40]
        with pytest.raises(BagError, match='no topic /nope'):
            list(source.messages(['/nope']))


# -- errors ----------------------------------------------------------------------------


def test_missing_path(tmp_path: Path) -> None:
    with pytest.raises(BagError, match=r'nothing_here: does not exist'):
        read_joint_states(tmp_path / 'nothing_here')


@pytest.mark.parametrize('name', ['garbage.mcap', 'garbage.db3', 'garbage.txt'])
def test_garbage_file(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(b'this is not a bag at all\n' * 100)
    with pytest.raises(BagError) as info:
        read_joint_states(path)
    message = str(info.value)
    assert str(path) in message and '\n' not in message
    assert any(word in message for word in ('not an MCAP file', 'not a bag', 'cannot read'))


def test_directory_that_is_not_a_bag(tmp_path: Path) -> None:
    (tmp_path / 'notes.txt').write_text('hello')
    with pytest.raises(BagError, match='not a rosbag2 bag'):
        open_bag(tmp_path)


def test_truncated_bare_mcap(tmp_path: Path) -> None:
    path = write_bare_mcap(tmp_path / 'run.mcap', robot(2, 3000))
    data = path.read_bytes()
    path.write_bytes(data[:len(data) * 2 // 3])
    with pytest.raises(BagError, match=r'run\.mcap: truncated MCAP file ') as caught:
        read_joint_states(path)
    # the hint is the command line, for the file itself (a bare .mcap has no bag directory)
    assert str(caught.value).endswith(
        f': recover it with: scara-ident recover {shlex.quote(str(path))}')
    assert 'recover_bag' not in str(caught.value)


def test_truncated_file_in_a_bag_directory_names_the_file(tmp_path: Path) -> None:
    bag = write_robot_bag(tmp_path / 'bag', robot(2, 3000), storage='mcap')
    file = next(bag.glob('*.mcap'))
    file.write_bytes(file.read_bytes()[:-100])
    with pytest.raises(BagError, match=rf'{file.name}: truncated MCAP file') as caught:
        open_bag(bag)
    assert str(caught.value).endswith(
        f'recover it with: scara-ident recover {shlex.quote(str(bag))}')


def test_recording_without_metadata_points_to_recovery(tmp_path: Path) -> None:
    bag = write_robot_bag(tmp_path / 'bag', robot(2, 10), storage='mcap')
    (bag / 'metadata.yaml').unlink()
    with pytest.raises(BagError, match='not closed; recover it') as caught:
        open_bag(bag)
    assert str(caught.value).endswith(
        f'recover it with: scara-ident recover {shlex.quote(str(bag))}')


def test_corrupt_chunk_is_reported_while_reading(tmp_path: Path) -> None:
    path = write_bare_mcap(tmp_path / 'run.mcap', robot(2, 30000))
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 64] = bytes(64)  # zeros in the middle of a compressed chunk
    path.write_bytes(bytes(data))
    with pytest.raises(BagError, match=r'run.mcap: (corrupt data after \d+ messages|cannot read)'):
        read_joint_states(path)


def test_missing_storage_file_listed_in_metadata(tmp_path: Path) -> None:
    bag = write_robot_bag(tmp_path / 'bag', robot(2, 10), storage='mcap')
    moved = tmp_path / 'elsewhere'
    moved.mkdir()
    for file in bag.glob('*.mcap'):
        shutil.move(file, moved / file.name)
    with pytest.raises(BagError, match=r'bag: cannot read bag: .*missing'):
        open_bag(bag)


def test_no_joint_state_topic_lists_the_topics(tmp_path: Path) -> None:
    bag = write_rosbags_bag(tmp_path / 'bag', {
        '/mse': (FLOAT64_ARRAY, [(1, float_array([1.0])), (2, float_array([2.0]))])})
    with pytest.raises(BagError, match=r'no sensor_msgs/msg/JointState topic \(the bag has '
                                        r'/mse \(std_msgs/msg/Float64MultiArray, 2 msgs\)\)'):
        read_joint_states(bag)


def test_ambiguous_joint_state_topics(tmp_path: Path) -> None:
    messages = [(1, joint_state(1, ['a'], [1.0])), (2, joint_state(2, ['a'], [2.0]))]
    bag = write_rosbags_bag(tmp_path / 'bag', {'/left/joint_states': (JOINT_STATE, messages),
                                               '/right/joint_states': (JOINT_STATE, messages)})
    with pytest.raises(BagError, match=r'2 sensor_msgs/msg/JointState topics and none is '
                                        r'/joint_states \(/left/joint_states, '
                                        r'/right/joint_states\); choose one'):
        read_joint_states(bag)
    assert len(read_joint_states(bag, topic='/right/joint_states')) == 2


def test_topic_that_is_not_joint_state(tmp_path: Path) -> None:
    bag = write_rosbags_bag(tmp_path / 'bag', {'/mse': (FLOAT64_ARRAY, [(1, float_array([]))])})
    with pytest.raises(BagError, match='/mse is not a sensor_msgs/msg/JointState topic'):
        read_joint_states(bag, topic='/mse')


def test_too_few_samples(tmp_path: Path) -> None:
    bag = write_robot_bag(tmp_path / 'bag', robot(2, 1))
    with pytest.raises(BagError, match=r'1 usable .* need at least 2'):
        read_joint_states(bag)
    with pytest.raises(BagError, match=r"0 usable .* naming \['elbow'\] .*joint1, joint2"):
        read_joint_states(write_robot_bag(tmp_path / 'bag2', robot(2, 50)), joints=['elbow'])
