"""recover_bag turns what a killed recorder left into a bag every reader opens."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
import yaml
from rosbags.highlevel import AnyReader

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bag_files import FLOAT64_ARRAY, JOINT_STATE, float_array, joint_state  # noqa: E402

from scara_ident_ros.bag import BagError, BagWriter, open_bag, recover_bag  # noqa: E402


def killed_recording(path: Path, count: int, *, cut: int, **options):  # type: ignore
    """Write ``count`` messages, 'kill' the writer (no close) and cut ``cut`` bytes off the
    last file, as a SIGKILL in the middle of writing a chunk would; return the messages."""
    writer = BagWriter(path, chunk_size=8 * 1024, **options).open()
    js = writer.add_connection('/joint_states', JOINT_STATE)
    mse = writer.add_connection('/mse', FLOAT64_ARRAY)
    written = []
    for i in range(count):
        t = 10**9 + i * 10**6
        written.append(('/joint_states', t, joint_state(t, ['a', 'b'], [i, i], [0, 0])))
        writer.write(js.id, t, written[-1][2])
        if i % 50 == 0:
            written.append(('/mse', t + 1, float_array([i])))
            writer.write(mse.id, t + 1, written[-1][2])
    last = path / writer.file_names[-1]
    writer.abort()  # the open chunk never reaches the disk
    if cut:
        last.write_bytes(last.read_bytes()[:-cut])
    return written


def read_all(path: Path) -> list[tuple[str, int, bytes]]:
    with open_bag(path) as bag:
        return [(m.topic, m.log_time_ns, m.data) for m in bag.messages()]


@pytest.mark.parametrize('compression', ['none', 'zstd', 'lz4'])
def test_killed_recording_recovers_up_to_the_last_complete_chunk(tmp_path: Path,
                                                                 compression: str) -> None:
    bag = tmp_path / 'bag'
    written = killed_recording(bag, 2000, cut=1000, compression=compression)
    with pytest.raises(BagError, match='recover it'):
        open_bag(bag)
    report = recover_bag(bag)
    (file,) = report.files
    assert file.rewritten and file.lost_bytes > 0 and 'cut off' in file.reason
    got = read_all(bag)
    assert got == written[:len(got)]  # a prefix, in order
    assert len(got) > len(written) - 200  # lost: < two 8 KiB chunks of ~110-byte messages
    assert report.message_count == len(got)
    assert report.topics['/joint_states'] + report.topics['/mse'] == len(got)
    assert (bag / f'{file.name}.damaged').is_file()
    with AnyReader([bag]) as reader:
        assert sum(1 for _ in reader.messages()) == len(got)


def test_split_recording_keeps_intact_files_and_rewrites_the_last(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    written = killed_recording(bag, 3000, cut=500, max_file_size=40_000)
    report = recover_bag(bag, keep_damaged=False)
    assert len(report.files) >= 4
    assert [f.rewritten for f in report.files] == [False] * (len(report.files) - 1) + [True]
    assert not list(bag.glob('*.damaged'))
    got = read_all(bag)
    assert got == written[:len(got)] and len(got) > len(written) - 200
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['relative_file_paths'] == [f.name for f in report.files]
    assert info['message_count'] == len(got)
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert topics['/joint_states']['topic_metadata']['type'] == JOINT_STATE
    assert topics['/joint_states']['topic_metadata']['type_description_hash'].startswith(
        'RIHS01_')


@pytest.mark.parametrize('keep', [100, 8, 3, 0])
def test_files_cut_right_after_the_start_recover_to_what_they_hold(tmp_path: Path,
                                                                   keep: int) -> None:
    bag = tmp_path / 'bag'
    killed_recording(bag, 10, cut=0)
    file = next(bag.glob('*.mcap'))
    file.write_bytes(file.read_bytes()[:keep])
    report = recover_bag(bag)
    assert report.message_count == 0
    with open_bag(bag) as source:
        assert list(source.messages()) == []


def test_recovery_is_idempotent_and_leaves_intact_bags_alone(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    killed_recording(bag, 500, cut=300)
    first = recover_bag(bag)
    data = {p.name: p.read_bytes() for p in bag.glob('*.mcap')}
    second = recover_bag(bag)
    assert not any(f.rewritten for f in second.files)
    assert second.message_count == first.message_count
    assert {p.name: p.read_bytes() for p in bag.glob('*.mcap')} == data


def test_bare_mcap_file(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    written = killed_recording(bag, 800, cut=100)
    file = next(bag.glob('*.mcap'))
    bare = tmp_path / 'run.mcap'
    file.rename(bare)
    report = recover_bag(bare)
    assert report.files[0].rewritten
    got = read_all(bare)
    assert got == written[:len(got)] and got


def test_errors(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='nope: does not exist'):
        recover_bag(tmp_path / 'nope')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BagError, match='no .mcap file to recover'):
        recover_bag(tmp_path / 'empty')
    garbage = tmp_path / 'garbage.mcap'
    garbage.write_bytes(b'GARBAGE!' * 100)
    with pytest.raises(BagError, match='garbage.mcap: not an MCAP file'):
        recover_bag(garbage)
