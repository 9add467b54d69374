"""``scara-ident run``: arguments checked before anything starts (no graph is run here)."""
from __future__ import annotations

from pathlib import Path

import pytest

from scara_ident_ros.cli import build_parser, main
from scara_ident_ros.sim import SEQUENCE, TRAJECTORIES


def test_the_default_trajectory_is_the_sequence() -> None:
    args = build_parser('run').parse_args(['run'])
    assert args.trajectory == SEQUENCE


@pytest.mark.parametrize('argv, named', [
    (['--trajectory', 'wild'], '--trajectory'),
    (['--duration', '0'], '--duration'),
    (['--methods', 'ffmw', 'ffmw'], 'twice'),
], ids=['unknown trajectory', 'zero duration', 'a method twice'])
def test_bad_arguments_end_in_one_line_before_anything_starts(
        argv: list[str], named: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'out'
    assert main(['run', '--out', str(out), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('scara-ident run: error:') and named in err[0]
    if named == '--trajectory':
        assert all(name in err[0] for name in TRAJECTORIES)
    assert not out.exists()


def test_an_out_that_cannot_hold_the_run_is_refused_first(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a_file = tmp_path / 'file'
    a_file.write_text('')
    for out in (a_file, Path('/proc/run')):
        assert main(['run', '--out', str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f'--out {out}' in err[0], err


def test_every_published_sample_is_accounted_for() -> None:
    """predicted + skipped + lost + not drained = published; the shortfall is what was not
    predicted."""
    from scara_ident_ros.cli.run_summary import MethodRow, stream_use

    info = {'processed': 9_000, 'predicted': 8_700, 'skipped': {'warming_up': 20,
                                                                'out_of_limits': 280},
            'lost': 400, 'learnt': 8_000}
    use = stream_use(10_000, info)
    assert use.not_drained == 600
    assert use.predicted is not None and use.lost is not None
    assert use.predicted + use.skipped.total + use.lost + use.not_drained == 10_000
    assert use.shortfall == 1_300
    whole = stream_use(10_000, {'processed': 10_000, 'predicted': 10_000, 'skipped': {},
                                'lost': 0})
    assert whole.not_drained == whole.shortfall == 0
    assert stream_use(None, info).not_drained is None
    # summary.json's row: the stream use inline, skipped per reason and its total
    row = MethodRow.of(info, 10_000, 8_700, 'ffs.npz').as_dict()
    assert row['skipped'] == info['skipped'] and row['skipped_total'] == 300
    assert row['learnt'] == 8_000 and row['not_drained'] == 600 and row['recorded'] == 8_700
