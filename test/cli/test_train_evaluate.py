"""``scara-ident train`` and ``evaluate`` on bags written by other tools, and every bad input."""
from __future__ import annotations

import shlex
import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.cli import main
from scara_ident_ros.identification import OnlineIdentifier
from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.nn import FeedForwardNet

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'bag'))
from bag_files import write_bare_mcap  # noqa: E402  (not a package)
from fake_bags import States, synthetic_states, write_rosbag, write_run_bag  # noqa: E402
from in_process_cli import assert_one_line_error, run_cli  # test/in_process_cli.py

SHIPPED = Path(__file__).resolve().parents[2] / 'bags' / 'demo_run'
#: Foreign bags: a rosbag2 directory written by rosbags (sqlite3 storage), a bare ``.mcap``
#: written by mcap-ros2-support.
FORMATS = ('sqlite3', 'mcap')


def write_bag(fmt: str, path: Path, states: States) -> Path:
    """``states`` as a bag of format ``fmt`` (one of `FORMATS`) at ``path`` (+ ``.mcap``)."""
    if fmt == 'sqlite3':
        return write_rosbag(path, states, storage='sqlite3')
    return write_bare_mcap(path.with_name(path.name + '.mcap'), states)


def reordered(states: States, order: list[int]) -> States:
    """The same states with the joints in ``order`` inside each message."""
    return States(states.stamp_ns, tuple(states.names[j] for j in order),
                  states.position[:, order], states.velocity[:, order],
                  states.effort[:, order])


def table_rows(text: str) -> dict[str, list[str]]:
    """Rows of the Markdown tables in ``text``: first cell -> the other cells."""
    rows = {}
    for line in text.splitlines():
        if line.startswith('| '):
            cells = [c.strip() for c in line.strip('|').split('|')]
            if cells[0] != 'joint':  # the header
                rows[cells[0]] = cells[1:]
    return rows


@pytest.fixture(scope='module')
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp('bags')
    two = synthetic_states(2, 10.0, seed=1, rate_hz=200.0)
    six = synthetic_states(6, 2.0, seed=2)
    return {
        # joints in another order inside the messages: mapped back by name
        'sqlite2': write_rosbag(root / 'two_sqlite', two, storage='sqlite3', order=[1, 0]),
        'mcap6': write_bare_mcap(root / 'six.mcap', six),
        'mcap6_bag': write_rosbag(root / 'six_bag', six, storage='mcap',
                                  topic='/robot/joint_states'),
    }


def assert_finite(rows: dict[str, list[str]]) -> None:
    assert rows and all(np.isfinite(float(cell)) for row in rows.values() for cell in row)


@pytest.mark.parametrize('n_joints', [2, 6])
@pytest.mark.parametrize('fmt', FORMATS)
def test_train_then_evaluate(fmt: str, n_joints: int, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    states = synthetic_states(n_joints, 2.0, seed=n_joints, rate_hz=500.0)
    # the joints in reverse order inside the messages: the model keeps that order
    order = list(range(n_joints))[::-1]
    trained = [f'joint{j + 1}' for j in order]
    labels = [f'{name} (N·m or N)' for name in trained] + ['mean']
    model = tmp_path / 'models' / 'ffmw.npz'
    code, out, err = run_cli(capsys, 'train', write_bag(fmt, tmp_path / 'run',
                                                        reordered(states, order)),
                             '--method', 'ffmw', '--iterations', '10', '--samples', '400',
                             '--later-fraction', '0', '--out', model)
    assert code == 0, err
    assert '/10 mse ' in err and 'stopped:' in err  # the progress bar, on stderr
    # 2 s at 500 Hz, every sample: the centred q'' loses none to a warm-up
    assert f'1000 samples of {n_joints} joints {trained}' in out
    # 20 % of 2 blocks of 1 s: one of them validates, the training samples come from the other
    assert 'training on 400, validating on 500 in 1 block of 1 s from ' in out
    rows = table_rows(out)
    assert list(rows) == labels
    assert_finite(rows)
    assert float(rows['mean'][1]) < 0.01  # training NMSE
    network = FeedForwardNet.load(model)
    assert (network.n_inputs, network.n_outputs) == (3 * n_joints, n_joints)
    assert list(network.metadata['joint_names']) == trained
    assert str(network.metadata['method']) == 'ffmw'
    assert bool(network.metadata['friction_steps'])  # the default
    assert network.activation == METHODS['ffmw'].activation
    assert network.scaling_set

    # the same motion sampled at 1 kHz, joints in natural order: mapped back by name
    other = write_bag(fmt, tmp_path / 'other',
                      synthetic_states(n_joints, 1.0, seed=n_joints, rate_hz=1000.0))
    code, out, err = run_cli(capsys, 'evaluate', model, other)
    assert code == 0, err
    assert 'FFMW model' in out and '1000 samples over 1.0 s' in out and 'mapped by name' in out
    rows = table_rows(out)
    assert list(rows) == labels
    assert all(len(row) == 2 for row in rows.values())  # MSE, NMSE
    assert_finite(rows)
    assert float(rows['mean'][1]) < 0.2


def test_train_and_evaluate_the_shipped_bag(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """bags/demo_run: 10 s of the project's own graph, the identifiers' JointStates too."""
    model = tmp_path / 'demo.npz'
    code, out, err = run_cli(capsys, 'train', SHIPPED, '--method', 'ffmw', '--iterations', '3',
                             '--samples', '500', '--out', model)
    assert code == 0, err
    # /joint_states of the several JointState topics (/ffmw/identified_torque, ...)
    assert f'{SHIPPED} /joint_states: ' in out and 'training on 500' in out
    network = FeedForwardNet.load(model)
    assert isinstance(network, FeedForwardNet)
    assert (network.n_inputs, network.n_outputs) == (12, 4)
    names = [f'joint{i + 1}' for i in range(4)]
    assert list(network.metadata['joint_names']) == names

    code, out, err = run_cli(capsys, 'evaluate', model, SHIPPED)
    assert code == 0, err
    assert f'FFMW model {model} on {SHIPPED} /joint_states: ' in out
    rows = table_rows(out)
    assert [label.split()[0] for label in rows] == [*names, 'mean']
    assert all(len(row) == 2 for row in rows.values())
    assert_finite(rows)


def test_identifier_warm_starts_from_a_trained_model(bags: dict[str, Path], tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    model = tmp_path / 'ffs.npz'
    code, _, err = run_cli(capsys, 'train', bags['sqlite2'], '--method', 'ffs',
                           '--algorithm', 'gd', '--iterations', '5', '--no-friction-steps',
                           '--out', model)
    assert code == 0, err
    network = FeedForwardNet.load(model)
    assert not bool(network.metadata['friction_steps'])
    names = [str(n) for n in network.metadata['joint_names']]
    # what the identifier node does with model_path: names from the metadata, learn on
    online = OnlineIdentifier(network, joint_names=names)
    states = synthetic_states(2, 0.05, seed=1)
    for i in range(states.stamp_ns.shape[0]):
        online.process(int(states.stamp_ns[i]), states.names, states.position[i],
                       states.velocity[i], states.effort[i])
    # every sample is learnt, the last 10 (waiting for the centred q'') at the end of the
    # stream, as the node does on shutdown
    assert online.counts.learnt + online.counts.pending == states.stamp_ns.shape[0]
    assert online.counts.pending == 10
    online.finish()
    assert online.counts.learnt == states.stamp_ns.shape[0] and online.counts.pending == 0


def test_six_joints_bare_mcap_with_joint_selection(bags: dict[str, Path], tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / 'ffw.npz'
    code, out, err = run_cli(capsys, 'train', bags['mcap6'], '--method', 'ffw',
                             '--iterations', '8', '--samples', '500', '--seed', '3',
                             '--joints', 'joint5', 'joint2', 'joint6', '--out', model)
    assert code == 0, err
    assert 'training on 500' in out
    network = FeedForwardNet.load(model)
    assert (network.n_inputs, network.n_outputs) == (9, 3)
    assert list(network.metadata['joint_names']) == ['joint5', 'joint2', 'joint6']
    # evaluated on the 6-joint bag directory under another topic: the model's 3 joints
    code, out, err = run_cli(capsys, 'evaluate', model, bags['mcap6_bag'])
    assert code == 0, err
    assert list(table_rows(out)) == ['joint5 (N·m or N)', 'joint2 (N·m or N)',
                                     'joint6 (N·m or N)', 'mean']
    # all six joints by default
    code, out, err = run_cli(capsys, 'train', bags['mcap6_bag'], '--method', 'ffmw',
                             '--iterations', '3', '--validation-fraction', '0',
                             '--out', tmp_path / 'six.npz')
    assert code == 0, err
    assert FeedForwardNet.load(tmp_path / 'six.npz').n_outputs == 6
    assert 'validation' not in table_rows(out).get('mean', [''])[0]


def _bad_bags(root: Path) -> dict[str, tuple[Path, str]]:
    """Bags that cannot be trained on, and what their error line must say."""
    states = synthetic_states(2, 1.0)
    full = write_bare_mcap(root / 'full.mcap', states)
    truncated = root / 'truncated.mcap'
    truncated.write_bytes(full.read_bytes()[:full.stat().st_size // 2])
    corrupt = root / 'corrupt.mcap'
    corrupt.write_bytes(b'\x89MCAP0\r\n' + bytes(range(256)) * 20 + b'\x89MCAP0\r\n')
    garbage_bag = root / 'garbage_bag'
    garbage_bag.mkdir()
    (garbage_bag / 'metadata.yaml').write_text('rosbag2_bagfile_information: [not, a, bag\n')
    few = write_rosbag(root / 'few', synthetic_states(2, 0.01))  # 10 messages
    no_effort = write_rosbag(root / 'no_effort', States(
        states.stamp_ns, states.names, states.position, states.velocity,
        np.zeros((states.stamp_ns.shape[0], 0))))
    return {
        'missing': (root / 'nope', r'nope.*does not exist'),
        'truncated': (truncated, r'truncated\.mcap: truncated MCAP file .*: recover it with: '
                                 r'scara-ident recover \S*truncated\.mcap$'),
        'corrupt': (corrupt, r'corrupt\.mcap'),
        'garbage_bag': (garbage_bag, r'garbage_bag'),
        # fewer samples than the centred q'' fit's window (21): none usable
        'few': (few, r'few.*0 usable samples of 10 messages \(skipped: 10 warming_up\).*'
                     r'need at least 20'),
        'no_effort': (no_effort, r'no_effort: /joint_states carries no effort for joint1, '
                                 r'joint2'),
    }


def test_bad_bags_give_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = _bad_bags(tmp_path)
    for name, (bag, pattern) in bad.items():
        assert_one_line_error(*run_cli(capsys, 'train', bag, '--method', 'ffmw', '--out',
                                       tmp_path / f'{name}.npz'), pattern)
        assert not (tmp_path / f'{name}.npz').exists()
    # a topic that is not there, and a joint no message has
    bag = write_rosbag(tmp_path / 'ok', synthetic_states(2, 0.2))
    assert_one_line_error(*run_cli(capsys, 'train', bag, '--method', 'ffs', '--topic', '/x',
                                   '--out', tmp_path / 'm.npz'), r'/x .*/joint_states')
    assert_one_line_error(*run_cli(capsys, 'train', bag, '--method', 'ffs', '--joints',
                                   'joint1', 'elbow', '--out', tmp_path / 'm.npz'),
                          r'no joint elbow \(its joints: joint1, joint2\)')
    # the identifiers' predictions are JointStates too, with effort only
    run = write_run_bag(tmp_path / 'run', synthetic_states(2, 0.2), methods=('ffmw',))
    assert_one_line_error(*run_cli(capsys, 'train', run, '--method', 'ffmw', '--topic',
                                   '/ffmw/identified_torque', '--out', tmp_path / 'm.npz'),
                          r'/ffmw/identified_torque carries no position for joint1, joint2')


def test_truncated_bag_names_the_recover_command(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    full = write_bare_mcap(tmp_path / 'full.mcap', synthetic_states(2, 1.0))
    bag = tmp_path / 'cut off.mcap'  # a space: the suggested command quotes the path
    bag.write_bytes(full.read_bytes()[:full.stat().st_size // 2])
    code, out, err = run_cli(capsys, 'train', bag, '--method', 'ffmw', '--out',
                             tmp_path / 'm.npz')
    assert_one_line_error(code, out, err, r'truncated MCAP file')
    assert 'recover_bag' not in err
    hint = ': recover it with: '
    assert hint in err
    command = shlex.split(err.strip().split(hint)[-1])
    assert command == ['scara-ident', 'recover', str(bag)]
    # the command as suggested runs; the bag is no longer truncated (but empty: one chunk)
    assert main(command[1:]) == 0
    assert_one_line_error(*run_cli(capsys, 'train', bag, '--method', 'ffmw', '--out',
                                   tmp_path / 'm.npz'), r'no sensor_msgs/msg/JointState')


def test_no_joint_state_topic_lists_the_topics(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    states = synthetic_states(2, 0.1)
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / 'floats'
    with Writer(bag, version=8) as writer:
        conn = writer.add_connection('/temperature', 'std_msgs/msg/Float64', typestore=store)
        for stamp in states.stamp_ns[:5].tolist():
            msg = store.types['std_msgs/msg/Float64'](data=1.0)
            writer.write(conn, stamp, store.serialize_cdr(msg, 'std_msgs/msg/Float64'))
    assert_one_line_error(*run_cli(capsys, 'train', bag, '--method', 'ffmw', '--out',
                                   tmp_path / 'm.npz'),
                          r'no sensor_msgs/msg/JointState topic.*/temperature')
    assert_one_line_error(*run_cli(capsys, 'evaluate', tmp_path / 'm.npz', bag),
                          r'm\.npz: no such model file')


def test_bad_models_give_one_line(bags: dict[str, Path], tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    text = tmp_path / 'notes.npz'
    text.write_text('not a model\n')
    code, out, err = run_cli(capsys, 'evaluate', text, bags['sqlite2'])
    assert_one_line_error(code, out, err, r'notes\.npz: not a \.npz network file \(not a '
                                          r'zip/\.npz archive\)$')
    assert 'pickle' not in err  # numpy's advice on unpickling has no place here
    # a directory given as MODEL (e.g. the --out directory of several models)
    (tmp_path / 'models').mkdir()
    assert_one_line_error(*run_cli(capsys, 'evaluate', tmp_path / 'models', bags['sqlite2']),
                          r'models: is a directory, not a model file')
    other = tmp_path / 'other.npz'
    np.savez(other, weights=np.zeros(3))
    assert_one_line_error(*run_cli(capsys, 'evaluate', other, bags['sqlite2']), r'other\.npz')
    # a network that is not 3n -> n
    odd = FeedForwardNet(5, 4, 2)
    odd.save(tmp_path / 'odd.npz')
    assert_one_line_error(*run_cli(capsys, 'evaluate', tmp_path / 'odd.npz', bags['sqlite2']),
                          r'5 inputs and 2 outputs is not an inverse-dynamics model')
    # a 6-joint model without names on a 2-joint bag; a named one whose joints are absent
    six = FeedForwardNet(18, 4, 6)
    six.save(tmp_path / 'six.npz')
    assert_one_line_error(*run_cli(capsys, 'evaluate', tmp_path / 'six.npz', bags['sqlite2']),
                          r'model of 6 joints, but .* has 2')
    six.metadata['joint_names'] = np.array([f'joint{i + 1}' for i in range(6)])
    six.save(tmp_path / 'six_named.npz')
    assert_one_line_error(*run_cli(capsys, 'evaluate', tmp_path / 'six_named.npz',
                                   bags['sqlite2']),
                          r'no joint joint3, joint4, joint5, joint6 \(its joints: joint2, '
                          r'joint1\)')


def test_bad_options_give_one_line(bags: dict[str, Path], tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    for option, value in (('--validation-fraction', '1.0'), ('--iterations', '0')):
        assert_one_line_error(*run_cli(capsys, 'train', bags['sqlite2'], '--method', 'ffw',
                                       option, value, '--out', tmp_path / 'm.npz'), option)
    assert_one_line_error(*run_cli(capsys, 'train', bags['sqlite2'], '--method', 'ffw',
                                   '--out', tmp_path), r'is a directory')


@pytest.mark.parametrize('command', ['train', 'evaluate'])
def test_help_explains(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, '--help'])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    assert 'JointState' in text and 'RECORDING' in text and 'ROS 1' in text


def test_an_unwritable_model_path_is_refused_before_training(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = Path(__file__).resolve().parents[2] / 'bags' / 'demo_run'
    for out, pattern in ((tmp_path, r'is a directory'), (Path('/proc/m.npz'), r'/proc/m.npz')):
        code, stdout, err = run_cli(capsys, 'train', str(bag), '--method', 'ffs', '--out',
                                    str(out))
        assert_one_line_error(code, stdout, err, pattern)
        assert 'training on' not in stdout  # refused before reading the bag
