"""BagWriter bags read back, as one bag, with rosbags, with mcap + mcap_ros2 and with open_bag."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)
from rosbags.rosbag2 import Reader

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bag_files import FLOAT64_ARRAY, JOINT_STATE, float_array, joint_state  # noqa: E402

from scara_ident_ros.bag import BagError, BagWriter, open_bag, read_joint_states  # noqa: E402
from scara_ident_ros.bag.mcap_file import McapFileWriter  # noqa: E402

QOS = Qos(QosHistory.KEEP_LAST, 1000, QosReliability.RELIABLE, QosDurability.VOLATILE,
          QosTime(0, 0), QosTime(0, 0), QosLiveliness.AUTOMATIC, QosTime(0, 0), False)


def record(path: Path, count: int, **options) -> list[tuple[str, int, bytes]]:  # type: ignore
    """Write ``count`` joint states and every 10th an MSE array; return what was written."""
    written = []
    with BagWriter(path, **options) as writer:
        js = writer.add_connection('/joint_states', JOINT_STATE, offered_qos=[QOS])
        mse = writer.add_connection('/ffmw/identification_mse', FLOAT64_ARRAY)
        batch = []
        for i in range(count):
            t = 1_000_000_000 + i * 1_000_000
            batch.append((js.id, t, joint_state(t, ['joint1', 'joint2'], [i, -i], [1, 2],
                                                [3, 4])))
            if i % 10 == 0:
                batch.append((mse.id, t + 1, float_array([i, i / 2])))
        for first in range(0, len(batch), 97):
            writer.write_batch(batch[first:first + 97])
        topics = {js.id: '/joint_states', mse.id: '/ffmw/identification_mse'}
        written = [(topics[c], t, data) for c, t, data in batch]
    return written


@pytest.mark.parametrize('compression', ['none', 'zstd', 'lz4'])
def test_round_trip_with_rosbags_reader_and_anyreader(tmp_path: Path, compression: str) -> None:
    bag = tmp_path / 'bag'
    written = record(bag, 3000, compression=compression, chunk_size=64 * 1024)
    with Reader(bag) as reader:
        got = [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]
        assert got == written
        assert {c.topic: c.msgcount for c in reader.connections} == {
            '/joint_states': 3000, '/ffmw/identification_mse': 300}
    with AnyReader([bag]) as reader:  # checks the type hashes against the definitions
        messages = [reader.deserialize(d, c.msgtype) for c, _, d in reader.messages()]
        assert len(messages) == 3300
        assert list(messages[-1].position) == [2999.0, -2999.0]


def test_round_trip_with_mcap_and_mcap_ros2(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    written = record(bag, 2000, compression='zstd', chunk_size=32 * 1024)
    files = sorted(bag.glob('*.mcap'))
    assert [f.name for f in files] == ['bag_0.mcap']
    with files[0].open('rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics.message_count == 2200
        assert len(summary.chunk_indexes) >= 5
        decoded = list(reader.iter_decoded_messages(log_time_order=True))
    assert [(c.topic, m.log_time, m.data) for _, c, m, _ in decoded] == written
    assert decoded[0][3].name == ['joint1', 'joint2']
    channel = decoded[0][1]
    assert channel.metadata['topic_type_hash'].startswith('RIHS01_')
    assert 'reliability: reliable' in channel.metadata['offered_qos_profiles']


def test_metadata_has_counts_files_qos_and_hashes(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    record(bag, 500)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9 and info['storage_identifier'] == 'mcap'
    assert info['message_count'] == 550
    assert info['relative_file_paths'] == ['bag_0.mcap']
    assert info['starting_time']['nanoseconds_since_epoch'] == 1_000_000_000
    assert info['duration']['nanoseconds'] == 499 * 1_000_000  # last joint state
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    js = topics['/joint_states']
    assert js['message_count'] == 500
    assert js['topic_metadata']['type'] == JOINT_STATE
    assert js['topic_metadata']['type_description_hash'].startswith('RIHS01_')
    qos = js['topic_metadata']['offered_qos_profiles']
    assert qos[0]['reliability'] == 'reliable' and qos[0]['depth'] == 1000
    assert topics['/ffmw/identification_mse']['message_count'] == 50


@pytest.mark.parametrize('split', [{'max_file_size': 60_000},
                                   {'max_file_duration_ns': 400_000_000}])
def test_split_files_read_back_as_one_bag(tmp_path: Path, split: dict[str, int]) -> None:
    bag = tmp_path / 'bag'
    written = record(bag, 3000, chunk_size=16 * 1024, **split)
    files = [f'bag_{i}.mcap' for i in range(len(list(bag.glob('*.mcap'))))]
    assert len(files) >= 4
    assert all((bag / name).is_file() for name in files)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['relative_file_paths'] == [f'bag_{i}.mcap' for i in range(len(files))]
    assert sum(f['message_count'] for f in info['files']) == len(written)
    with AnyReader([bag]) as reader:
        got = [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]
    assert got == written
    with open_bag(bag) as source:
        assert [(m.topic, m.log_time_ns, m.data) for m in source.messages()] == written
    assert len(read_joint_states(bag)) == 3000
    if 'max_file_size' in split:
        sizes = [(bag / name).stat().st_size for name in files]
        assert max(sizes) < 60_000 + 17 * 1024


def test_refuses_to_overwrite(tmp_path: Path) -> None:
    (tmp_path / 'bag').mkdir()
    with pytest.raises(BagError, match='bag exists already, not overwriting'):
        BagWriter(tmp_path / 'bag')


def test_bad_options_and_unknown_connection(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='compression must be one of none, zstd, lz4'):
        BagWriter(tmp_path / 'a', compression='bz2')
    with BagWriter(tmp_path / 'b') as writer:
        with pytest.raises(BagError, match='unknown channel 7'):
            writer.write(7, 1, b'')
        connection = writer.add_connection('/x', FLOAT64_ARRAY)
        with pytest.raises(BagError, match='/x is already recorded'):
            writer.add_connection('/x', FLOAT64_ARRAY)
        writer.write(connection.id, 5, float_array([1.0]))
    assert open_bag(tmp_path / 'b').topics == {'/x': (FLOAT64_ARRAY, 1)}


def test_empty_bag_is_a_valid_bag(tmp_path: Path) -> None:
    with BagWriter(tmp_path / 'bag') as writer:
        writer.add_connection('/joint_states', JOINT_STATE)
    with open_bag(tmp_path / 'bag') as source:
        assert source.topics == {'/joint_states': (JOINT_STATE, 0)}
        assert list(source.messages()) == []


def test_a_chunk_reaches_the_disk_when_full_or_old(tmp_path: Path) -> None:
    now = [0]
    path = tmp_path / 'f.mcap'
    with McapFileWriter(path, chunk_size=10_000, chunk_duration_ns=1_000_000_000,
                        clock=lambda: now[0]) as writer:
        writer.add_schema(1, FLOAT64_ARRAY, 'ros2msg', b'')
        writer.add_channel(1, 1, '/x')
        header_size = path.stat().st_size
        writer.write(1, 1, b'x' * 100)
        assert path.stat().st_size == header_size  # still in memory
        now[0] = 999_999_999
        writer.poll()
        assert path.stat().st_size == header_size
        now[0] = 1_000_000_000
        writer.poll()  # one second old: written and flushed
        assert path.stat().st_size > header_size + 100
        size = path.stat().st_size
        writer.write_batch([(1, 2, b'y' * 6000), (1, 3, b'z' * 6000)])  # full: written
        assert path.stat().st_size > size + 10_000
