"""trim_bag copies a bag of earlier versions (identified_torque with 8 bytes past its data,
which rosbags refuses) into one every reader reads, and changes nothing else (issue 26)."""
from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bag_files import (FLOAT64_ARRAY, JOINT_STATE, OLD_SLACK, STORE, float_array,  # noqa: E402
                       joint_state, robot, write_old_identifier_bag, write_rosbags_bag)

from scara_ident_ros.bag import BagError, open_bag, read_joint_states, trim_bag  # noqa: E402
from scara_ident_ros.bag.exact_cdr import exact_joint_state  # noqa: E402
from scara_ident_ros.bag.recording_file import read_recording  # noqa: E402
from scara_ident_ros.cli import main as cli_main  # noqa: E402

QOS = Qos(QosHistory.KEEP_LAST, 1000, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
          QosTime(0, 0), QosTime(0, 0), QosLiveliness.AUTOMATIC, QosTime(0, 0), False)
TORQUE = '/ffs/identified_torque'
EXTERNAL = '/ffs/external_torque'


def digest(path: Path) -> dict[str, str]:
    """File name -> SHA-256 of every file under ``path``."""
    files = [path] if path.is_file() else sorted(p for p in path.rglob('*') if p.is_file())
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def anyreader_messages(path: Path) -> dict[str, list[tuple[int, object]]]:
    """Every message of the bag deserialized by rosbags' AnyReader, per topic."""
    got: dict[str, list[tuple[int, object]]] = {}
    with AnyReader([path]) as reader:
        for connection, log_ns, raw in reader.messages():
            got.setdefault(connection.topic, []).append(
                (log_ns, reader.deserialize(raw, connection.msgtype)))
    return got


@pytest.fixture()
def old_bag(tmp_path: Path) -> tuple[Path, dict[str, list[tuple[int, bytes]]]]:
    path = tmp_path / 'old'
    return path, write_old_identifier_bag(path, robot(3, 300, seed=4), offered_qos=[QOS])


def test_rosbags_refuses_an_old_bag_and_reads_its_copy(
        old_bag: tuple[Path, dict[str, list[tuple[int, bytes]]]], tmp_path: Path) -> None:
    path, written = old_bag
    with AnyReader([path]) as reader, pytest.raises(Exception, match='size mismatch'):
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
    before = digest(path)
    report = trim_bag(path, tmp_path / 'fixed')
    assert digest(path) == before  # the input is never changed
    assert report.trimmed == 2 * 300 and report.message_count == sum(map(len, written.values()))
    assert report.topics[TORQUE].bytes_removed == 300 * len(OLD_SLACK)
    assert report.topics['/joint_states'].trimmed == 0
    got = anyreader_messages(tmp_path / 'fixed')
    assert got.keys() == written.keys()
    for topic, messages in written.items():
        msgtype = JOINT_STATE if 'mse' not in topic else FLOAT64_ARRAY
        assert [t for t, _ in got[topic]] == [t for t, _ in messages]  # times as recorded
        for (_, msg), (_, data) in zip(got[topic], messages, strict=True):
            expected = STORE.deserialize_cdr(
                data[:-len(OLD_SLACK)] if topic in (TORQUE, EXTERNAL) else data, msgtype)
            if msgtype == JOINT_STATE:
                assert msg.name == expected.name
                assert msg.header.stamp == expected.header.stamp
                for key in ('position', 'velocity', 'effort'):
                    np.testing.assert_array_equal(getattr(msg, key), getattr(expected, key))
            else:
                np.testing.assert_array_equal(msg.data, expected.data)


def test_the_copy_differs_only_in_the_cut_bytes(
        old_bag: tuple[Path, dict[str, list[tuple[int, bytes]]]], tmp_path: Path) -> None:
    path, written = old_bag
    trim_bag(path, tmp_path / 'fixed')
    fixed = tmp_path / 'fixed'
    assert sorted(p.name for p in fixed.iterdir()) == sorted(p.name for p in path.iterdir())
    assert (fixed / 'metadata.yaml').read_bytes() == (path / 'metadata.yaml').read_bytes()
    (old_file,) = path.glob('*.mcap')
    views = []
    for file in (old_file, fixed / old_file.name):
        with file.open('rb') as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            assert summary is not None
            channels = {c.topic: (c.message_encoding, dict(c.metadata),
                                  summary.schemas[c.schema_id].name,
                                  summary.schemas[c.schema_id].data)
                        for c in summary.channels.values()}
            messages = [(channel.topic, m.log_time, m.publish_time, m.sequence, m.data)
                        for _, channel, m in reader.iter_messages(log_time_order=False)]
            views.append((channels, messages, reader.get_header().profile,
                          len(summary.chunk_indexes),
                          {c.compression for c in summary.chunk_indexes}))
    (old_channels, old_messages, *old_rest), (new_channels, new_messages, *new_rest) = views
    assert new_channels == old_channels  # QoS, type hash, schemas
    assert 'transient_local' in new_channels[TORQUE][1]['offered_qos_profiles']
    assert new_rest == old_rest and old_rest[1] > 1  # profile, chunks, compression
    assert len(new_messages) == len(old_messages)
    for old, new in zip(old_messages, new_messages):
        assert new[:4] == old[:4]
        assert new[4] == (old[4][:-len(OLD_SLACK)] if old[0] in (TORQUE, EXTERNAL) else old[4])
    # mcap-ros2-support decodes every message of the copy with the schemas it stores
    decoded = 0
    with (fixed / old_file.name).open('rb') as stream:
        for _, _, _, msg in make_reader(stream, decoder_factories=[DecoderFactory()]
                                        ).iter_decoded_messages():
            decoded += 1
    assert decoded == len(new_messages)


def test_the_package_readers_read_old_bags_as_they_are(
        old_bag: tuple[Path, dict[str, list[tuple[int, bytes]]]], tmp_path: Path) -> None:
    """train, evaluate, tables and play read the old bag without a repair, and the same
    values as from the copy."""
    from scara_ident_ros.paper.online_results import read_online_predictions

    path, _ = old_bag
    trim_bag(path, tmp_path / 'fixed')
    for topic in ('/joint_states', TORQUE, EXTERNAL):
        old = read_joint_states(path, topic=topic)
        new = read_joint_states(tmp_path / 'fixed', topic=topic)
        for key in ('stamp_ns', 'position', 'velocity', 'effort'):
            np.testing.assert_array_equal(getattr(old, key), getattr(new, key))
        assert len(old) == 300 and np.isfinite(old.effort).all()
    series = read_recording(path)
    assert series.topic == '/joint_states' and len(series) == 300
    predictions = read_online_predictions(path, 'ffs', series)  # what tables reads
    assert predictions is not None and predictions.n_unmatched == 0
    np.testing.assert_allclose(predictions.predicted, series.effort * 1.01)


def test_sqlite3_bags_and_other_types_are_cut_too(tmp_path: Path) -> None:
    """A sqlite3 bag (rosbags' writer); a Float64MultiArray with 8 bytes past its data is
    cut, one with the 2 bytes of padding rosbags allows is left as it is."""
    states = robot(2, 20)
    stamps = states.stamp_ns.tolist()
    torque = [(t, joint_state(t, states.names, effort=row) + OLD_SLACK)
              for t, row in zip(stamps, states.effort)]
    arrays = [(t, float_array([float(i)]) + (b'\x00' * 8 if i % 2 else b'\x00\x00'))
              for i, t in enumerate(stamps)]
    path = write_rosbags_bag(tmp_path / 'old', {TORQUE: (JOINT_STATE, torque),
                                               '/mse': (FLOAT64_ARRAY, arrays)})
    before = digest(path)
    report = trim_bag(path, tmp_path / 'fixed')
    assert digest(path) == before
    assert (report.topics[TORQUE].trimmed, report.topics['/mse'].trimmed) == (20, 10)
    assert report.topics['/mse'].bytes_removed == 10 * 8
    got = anyreader_messages(tmp_path / 'fixed')
    assert [float(m.data[0]) for _, m in got['/mse']] == list(range(20))
    np.testing.assert_array_equal([m.effort for _, m in got[TORQUE]], states.effort)
    with open_bag(tmp_path / 'fixed') as bag:
        data: dict[str, list[bytes]] = {}
        for m in bag.messages():
            data.setdefault(m.topic, []).append(m.data)
    assert data[TORQUE] == [d[:-8] for _, d in torque]
    assert data['/mse'] == [d if i % 2 == 0 else d[:-8] for i, (_, d) in enumerate(arrays)]


def test_bare_mcap_file_and_the_command(
        old_bag: tuple[Path, dict[str, list[tuple[int, bytes]]]], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    path, _ = old_bag
    (file,) = path.glob('*.mcap')
    assert cli_main(['recover', str(file), '--exact-cdr', str(tmp_path / 'fixed.mcap')]) == 0
    out = capsys.readouterr().out
    assert '600 cut to their exact CDR length' in out and TORQUE in out
    assert len(anyreader_messages(tmp_path / 'fixed.mcap')[TORQUE]) == 300


def test_refusals(old_bag: tuple[Path, dict[str, list[tuple[int, bytes]]]],
                  tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path, _ = old_bag
    (tmp_path / 'taken').mkdir()
    with pytest.raises(BagError, match='exists already'):
        trim_bag(path, tmp_path / 'taken')
    with pytest.raises(BagError, match='exists already'):
        trim_bag(path, path)
    (file,) = path.glob('*.mcap')
    file.write_bytes(file.read_bytes()[:-100])  # killed recorder: recover first
    assert cli_main(['recover', str(path), '--exact-cdr', str(tmp_path / 'fixed')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'scara-ident recover' in err[0], err
    assert not (tmp_path / 'fixed').exists() and not (tmp_path / 'fixed.partial').exists()


def test_exact_joint_state() -> None:
    exact = joint_state(5, ['a', 'bb'], effort=[1.0, 2.0])
    assert exact_joint_state(exact + OLD_SLACK) == exact
    assert exact_joint_state(exact) is exact
    assert exact_joint_state(b'junk') == b'junk'
