"""The one reader of recordings, against files written here: a ROS 1 bag, CSV exports with
uneven stamps and repeated rows, a table without time, an npz without velocity; and a look at
the real recordings in ../shared/realdata when they are there."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.bag import BagError
from scara_ident_ros.bag.recording_file import (TIMELESS_PERIOD_S, read_recording,
                                                split_name)
from scara_ident_ros.identification.recording import load_recording

NAMES = ('shoulder', 'elbow')
_REPO = Path(__file__).resolve().parents[2]
#: ../shared/realdata beside the clone (CI), or beside the folder of a worktree; or
#: $SCARA_IDENT_REALDATA.
REAL = next((p for p in (Path(os.environ.get('SCARA_IDENT_REALDATA', _REPO / 'none')),
                         _REPO.parent / 'shared' / 'realdata',
                         _REPO.parent.parent / 'shared' / 'realdata') if p.is_dir()),
            _REPO.parent / 'shared' / 'realdata')


def motion(stamps_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q' (analytic) and an effort of two joints at the given times (s)."""
    t = stamps_s[:, None]
    omega = 2 * np.pi * np.array([0.5, 0.8])
    q = np.sin(omega * t) * [1.0, 0.5]
    qd = np.cos(omega * t) * omega * [1.0, 0.5]
    effort = 3.0 * q + 0.2 * qd
    return q, qd, effort


def uneven_stamps(count: int, seed: int = 0) -> np.ndarray:
    """Stamps (s) 0.7-8.8 ms apart around a nominal 1 kHz: mostly 1 ms, now and then long."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.7e-3, 1.3e-3, count - 1)
    steps[rng.choice(count - 1, count // 50, replace=False)] = rng.uniform(3e-3, 8.8e-3,
                                                                          count // 50)
    return np.concatenate(([0.0], np.cumsum(steps)))


def write_ros1_bag(path: Path, stamps_ns: np.ndarray, q: np.ndarray, qd: np.ndarray,
                   effort: np.ndarray) -> None:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    JointState = store.types['sensor_msgs/msg/JointState']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    with Writer(path) as writer:
        states = writer.add_connection('/joint_states', JointState.__msgtype__,
                                       typestore=store)
        other = writer.add_connection('/gripper/joint_states', JointState.__msgtype__,
                                      typestore=store)
        for k, stamp in enumerate(stamps_ns.tolist()):
            sec, nsec = divmod(stamp, 1_000_000_000)
            order = [1, 0] if k % 2 else [0, 1]  # the joints in either order
            msg = JointState(Header(k, Time(sec, nsec), ''), [NAMES[j] for j in order],
                             q[k, order], qd[k, order], effort[k, order])
            writer.write(states, stamp, store.serialize_ros1(msg, JointState.__msgtype__))
            if k % 10 == 0:
                grip = JointState(Header(k, Time(sec, nsec), ''), ['finger'],
                                  np.zeros(1), np.zeros(1), np.zeros(1))
                writer.write(other, stamp, store.serialize_ros1(grip, JointState.__msgtype__))


def test_a_ros1_bag_is_read_by_joint_name(tmp_path: Path) -> None:
    stamps = (1_000_000_000 + np.round(uneven_stamps(300) * 1e9)).astype(np.int64)
    q, qd, effort = motion((stamps - stamps[0]) * 1e-9)
    write_ros1_bag(tmp_path / 'run.bag', stamps, q, qd, effort)
    series = read_recording(tmp_path / 'run.bag')
    assert series.kind == 'ros1' and series.topic == '/joint_states'
    assert series.names == NAMES
    np.testing.assert_array_equal(series.stamp_ns, stamps)
    np.testing.assert_array_equal(series.position, q)
    np.testing.assert_array_equal(series.velocity, qd)
    np.testing.assert_array_equal(series.effort, effort)
    gripper = read_recording(tmp_path / 'run.bag', topic='/gripper/joint_states')
    assert gripper.names == ('finger',) and len(gripper) == 30
    recording = load_recording(tmp_path / 'run.bag', joints=['elbow', 'shoulder'])
    assert recording.samples.names == ('elbow', 'shoulder')
    assert len(recording.samples.data) == 300 and recording.samples.skipped == {}
    with pytest.raises(BagError, match='no .*JointState topic /nope'):
        read_recording(tmp_path / 'run.bag', topic='/nope')


def write_export(folder: Path, stamps_s: np.ndarray, q: np.ndarray, qd: np.ndarray,
                 effort: np.ndarray) -> None:
    """A /joint_states export as three CSV files, columns 't,- <joint>_<field>'."""
    folder.mkdir()
    for field, values in (('position', q), ('velocity', qd), ('effort', effort)):
        header = ','.join(['t', *(f'- {name}_{field}' for name in NAMES)])
        np.savetxt(folder / f'arm_{field}.csv', np.column_stack([stamps_s, values]),
                   delimiter=',', header=header, comments='', fmt='%.17g')


def test_a_csv_export_with_uneven_stamps_and_repeated_rows(tmp_path: Path) -> None:
    stamps = uneven_stamps(400)
    q, qd, effort = motion(stamps)
    resent = [50, 51, 200]  # the driver sent its last state again, under new stamps
    for k in resent:
        q[k], qd[k], effort[k] = q[k - 1], qd[k - 1], effort[k - 1]
    same_stamp = 300  # and once the same stamp twice, with another state
    stamps[same_stamp] = stamps[same_stamp - 1]
    write_export(tmp_path / 'export', stamps, q, qd, effort)
    for given in ('export', 'export/arm_velocity.csv', 'export/arm_effort.csv'):
        series = read_recording(tmp_path / given)
        assert series.kind == 'csv' and series.names == NAMES and len(series) == 400
        np.testing.assert_allclose(series.effort, effort, rtol=1e-15)
    recording = load_recording(tmp_path / 'export')
    assert recording.samples.skipped == {'repeated': 3, 'stamp_repeated': 1}
    assert len(recording.samples.data) == 400 - 4
    assert recording.samples.gaps == 0  # 8.8 ms steps at 1 kHz are not gaps


def test_a_csv_table_with_named_columns_and_its_errors(tmp_path: Path) -> None:
    stamps = np.arange(100) * 0.01
    q, qd, effort = motion(stamps)
    header = 't,q_a,q_b,qd_a,qd_b,tau_a,tau_b'
    np.savetxt(tmp_path / 'run.csv', np.column_stack([stamps, q, qd, effort]), delimiter=',',
               header=header, comments='')
    series = read_recording(tmp_path / 'run.csv')
    assert series.names == ('a', 'b') and series.timed and series.acceleration is None
    np.testing.assert_allclose(series.velocity, qd)
    np.savetxt(tmp_path / 'bad.csv', np.zeros((3, 2)), delimiter=',', header='t,speed',
               comments='')
    with pytest.raises(BagError, match="column 'speed' names no joint quantity"):
        read_recording(tmp_path / 'bad.csv')
    with pytest.raises(BagError, match='a table has no topics'):
        read_recording(tmp_path / 'run.csv', topic='/joint_states')


def test_a_table_without_time_trains_on_its_given_accelerations(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    X_train, X_test = rng.normal(size=(50, 6)), rng.normal(size=(20, 6))
    X_train[10] = X_train[9]  # a repeated row
    X_test[3, 4] = np.nan
    np.savez(tmp_path / 'arm.npz', X_train=X_train, Y_train=X_train[:, :2] * 2,
             X_test=X_test, Y_test=X_test[:, :2])
    assert split_name(tmp_path / 'arm.npz:train') == (tmp_path / 'arm.npz', 'train')
    with pytest.raises(BagError, match=r'a split named: .*arm\.npz:test, .*arm\.npz:train'):
        read_recording(tmp_path / 'arm.npz')
    with pytest.raises(BagError, match="no split 'valid'"):
        read_recording(f'{tmp_path / "arm.npz"}:valid')
    series = read_recording(f'{tmp_path / "arm.npz"}:train')
    assert not series.timed and series.topic == '(table):train'
    assert series.stamp_ns[1] - series.stamp_ns[0] == round(TIMELESS_PERIOD_S * 1e9)
    recording = load_recording(f'{tmp_path / "arm.npz"}:train')
    data = recording.samples.data
    assert data.acceleration == 'true' and len(data) == 49
    assert recording.samples.skipped == {'repeated': 1}
    np.testing.assert_array_equal(data.X, np.delete(X_train, 10, axis=0))  # q'' as given
    test = load_recording(f'{tmp_path / "arm.npz"}:test', minimum=5)
    assert len(test.samples.data) == 19 and test.samples.skipped == {'non_finite': 1}
    np.savez(tmp_path / 'loose.npz', q=X_train[:, :2], tau=X_train[:, :2])
    with pytest.raises(BagError, match='without time .* no velocity and no acceleration'):
        read_recording(tmp_path / 'loose.npz')


def test_an_npz_without_velocity_gets_it_from_its_positions(tmp_path: Path) -> None:
    stamps = uneven_stamps(3000, seed=2) * 0.2  # 5 kHz, uneven
    q, qd, effort = motion(stamps)
    np.savez(tmp_path / 'arm.npz', t=stamps, q=q, tau=effort, names=np.array(NAMES))
    series = read_recording(tmp_path / 'arm.npz')
    assert series.velocity_derived == NAMES and series.names == NAMES
    # a cubic over 20 ms (101 samples at 5 kHz: recording_window): exact but for its bias
    # on this smooth motion, 1e-5 of the largest speed
    np.testing.assert_allclose(series.velocity, qd, atol=3e-5 * np.abs(qd).max())
    recording = load_recording(tmp_path / 'arm.npz', joints=['elbow'])
    assert recording.samples.names == ('elbow',)
    assert len(recording.samples.data) == 3000
    with pytest.raises(BagError, match='no joint wrist in the recording'):
        load_recording(tmp_path / 'arm.npz', joints=['wrist'])


def test_what_is_no_recording_is_refused_in_one_line(tmp_path: Path) -> None:
    (tmp_path / 'notes.txt').write_text('hello')
    with pytest.raises(BagError, match='not a recording'):
        read_recording(tmp_path / 'notes.txt')
    with pytest.raises(BagError, match='does not exist'):
        read_recording(tmp_path / 'missing.npz')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BagError, match='neither a rosbag2 bag'):
        read_recording(tmp_path / 'empty')


@pytest.mark.skipif(not REAL.is_dir(), reason=f'no real recordings beside the clone ({REAL})')
@pytest.mark.parametrize('name, joints, rows, hz', [
    ('tiago', 8, 8022, 100.0),
    ('tx40/tx40_joint.npz', 6, 45000, 5000.0),
    ('barrett_wam.npz:train', 7, 12000, None),
    ('barrett_wam.npz:test', 7, 3000, None),
    ('sarcos_test.npz', 7, 4449, None),
])
def test_the_real_recordings_are_read(name: str, joints: int, rows: int,
                                      hz: float | None) -> None:
    series = read_recording(f'{REAL}/{name}')
    assert len(series.names) == joints and len(series) == rows
    assert np.isfinite(series.velocity).all() and np.isfinite(series.effort).all()
    assert series.timed == (hz is not None)
    if hz is not None:
        assert 1e9 / np.median(np.diff(series.stamp_ns)) == pytest.approx(hz, rel=1e-3)
