"""scara-ident recover: a bag cut off mid-chunk, without metadata, becomes readable."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from scara_ident_ros.bag import BagError, read_joint_states
from scara_ident_ros.cli import main

SHIPPED = Path(__file__).resolve().parents[2] / 'bags' / 'demo_run'


def test_recover_keeps_every_complete_chunk(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / 'killed'
    shutil.copytree(SHIPPED, bag)
    intact = read_joint_states(bag)
    (bag / 'metadata.yaml').unlink()  # a killed recorder never wrote it
    mcap = next(bag.glob('*.mcap'))
    with open(mcap, 'r+b') as handle:  # cut off in the middle of a chunk
        handle.truncate(mcap.stat().st_size * 2 // 3)
    with pytest.raises(BagError):
        read_joint_states(bag)

    assert main(['recover', str(bag)]) == 0
    assert 'rewritten' in capsys.readouterr().out
    recovered = read_joint_states(bag)
    assert 0.3 * len(intact.stamp_ns) < len(recovered.stamp_ns) < len(intact.stamp_ns)
    # What was kept is exactly the start of the recording.
    n = len(recovered.stamp_ns)
    assert (recovered.stamp_ns == intact.stamp_ns[:n]).all()
    assert (recovered.effort == intact.effort[:n]).all()
    assert (bag / f'{mcap.name}.damaged').exists()


def test_recover_reports_a_missing_bag_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(['recover', str(tmp_path / 'nothing')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'does not exist' in err[0]
