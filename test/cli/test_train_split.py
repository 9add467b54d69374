"""``scara-ident train``'s validation: time blocks spread over the recording, a late stop;
later motion held out (the split itself: test/identification/test_split.py)."""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.cli import main
from scara_ident_ros.cli import train as train_cli
from scara_ident_ros.nn import FeedForwardNet

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'bag'))
from bag_files import write_bare_mcap  # noqa: E402  (not a package)
from fake_bags import synthetic_states  # noqa: E402
from in_process_cli import assert_one_line_error, run_cli  # test/in_process_cli.py

#: ``validating on N in K blocks of B s from T0 s to T1 s``
VALIDATION = re.compile(r'training on (\d+), validating on (\d+) in (\d+) blocks? of ([\d.]+) s '
                        r'from ([\d.]+) s to ([\d.]+) s')
#: ``N iterations in T s (stopped: REASON; weights of iteration B)``
STOPPED = re.compile(r'(\d+) iterations in [\d.]+ s \(stopped: (\w+); weights of iteration '
                     r'(\d+)\)')


@pytest.fixture(scope='module')
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """20 s of 2 joints at 200 Hz: 4000 messages."""
    root = tmp_path_factory.mktemp('split')
    return write_bare_mcap(root / 'twenty.mcap', synthetic_states(2, 20.0, seed=4,
                                                                  rate_hz=200.0))


def test_validation_blocks_come_from_the_whole_recording(bag: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    model = tmp_path / 'm.npz'
    code, out, err = run_cli(capsys, 'train', bag, '--method', 'ffs', '--iterations', '3',
                             '--samples', '0', '--later-fraction', '0', '--out', model)
    assert code == 0, err
    found = VALIDATION.search(out)
    assert found, out
    n_train, n_val, blocks = int(found[1]), int(found[2]), int(found[3])
    first, last = float(found[5]), float(found[6])
    assert blocks == 4 and float(found[4]) == 1.0  # 20 % of 20 blocks of 1 s
    assert n_train + n_val == 4000 and n_val == 4 * 200  # whole blocks of 200 samples
    assert first < 5.0 and last > 15.0  # one in each fifth: not only the end (time_split)
    network = FeedForwardNet.load(model)
    assert float(network.metadata['validation_block_s']) == 1.0
    assert int(network.metadata['max_fail']) == train_cli.MAX_FAIL
    assert int(network.metadata['min_iterations']) == train_cli.MIN_ITERATIONS
    # the same seed, the same blocks; --validation-block sets their length
    code, again, err = run_cli(capsys, 'train', bag, '--method', 'ffs', '--iterations', '1',
                               '--later-fraction', '0', '--out', tmp_path / 'again.npz')
    assert code == 0, err
    assert VALIDATION.search(again)[0] == found[0]  # type: ignore[index]
    code, out, err = run_cli(capsys, 'train', bag, '--method', 'ffs', '--iterations', '1',
                             '--validation-block', '0.5', '--validation-fraction', '0.1',
                             '--later-fraction', '0', '--out', tmp_path / 'half.npz')
    assert code == 0, err
    found = VALIDATION.search(out)
    assert found and found.group(3, 4) == ('4', '0.5') and int(found[2]) == 4 * 100


def test_the_default_sample_count(bag: Path, tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_cli(capsys, 'train', bag, '--method', 'ffs', '--iterations', '1',
                             '--validation-fraction', '0', '--later-fraction', '0',
                             '--out', tmp_path / 'm.npz')
    assert code == 0, err
    expected = min(train_cli.SAMPLES, 4000) if train_cli.SAMPLES else 4000
    assert f'training on {expected}, validating on 0\n' in out


def test_early_stop_waits_for_min_iterations(bag: Path, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    # one validation failure would stop at once, but not within the first 12 iterations
    code, out, err = run_cli(capsys, 'train', bag, '--method', 'ffs', '--iterations', '40',
                             '--samples', '300', '--max-fail', '1', '--min-iterations', '12',
                             '--out', tmp_path / 'm.npz')
    assert code == 0, err
    found = STOPPED.search(out)
    assert found, out
    iterations, reason, best = int(found[1]), found[2], int(found[3])
    assert iterations >= 13 and reason in ('validation', 'iterations')
    if reason == 'validation':  # the first failure after iteration 12 stopped it: every
        # iteration from 13 to the last but one was a new best
        assert iterations == 13 or best == iterations - 1
    network = FeedForwardNet.load(tmp_path / 'm.npz')
    assert int(network.metadata['iterations']) == iterations
    assert int(network.metadata['max_fail']) == 1


def test_bad_split_options_give_one_line(bag: Path, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    short = write_bare_mcap(tmp_path / 'short.mcap', synthetic_states(2, 0.8, rate_hz=200.0))
    cases = [
        ((bag, '--validation-block', '0'), r'--validation-block must be positive'),
        ((bag, '--max-fail', '0'), r'--max-fail must be at least 1'),
        ((bag, '--min-iterations', '-1'), r'--min-iterations must not be negative'),
        ((bag, '--later-fraction', '1'), r'--later-fraction must be in \[0, 1\)'),
        # the earlier 70 % of 0.8 s
        ((short,), r'short\.mcap: 0\.55\d s of samples fill 1 block of 1 s; .*lower '
                   r'--validation-block, give --validation-fraction 0'),
    ]
    for argv, pattern in cases:
        assert_one_line_error(*run_cli(capsys, 'train', *argv, '--method', 'ffs',
                                       '--out', tmp_path / 'm.npz'), pattern)
    assert not (tmp_path / 'm.npz').exists()
    # the short bag trains without validation
    code, out, err = run_cli(capsys, 'train', short, '--method', 'ffs', '--iterations', '1',
                             '--validation-fraction', '0', '--out', tmp_path / 'm.npz')
    assert code == 0, err


def test_help_states_the_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(['train', '--help'])
    text = ' '.join(capsys.readouterr().out.split())
    assert 'blocks' in text and 'interleaved' in text and 'later motion' in text
    assert f'(default: {train_cli.LATER_FRACTION:g}; 0: on the validation blocks)' in text
    assert f'(default: {train_cli.MAX_FAIL})' in text
    assert f'(default: {train_cli.MIN_ITERATIONS})' in text
    assert f'(default: {train_cli.SAMPLES}; 0: all)' in text
    assert f'(default: {train_cli.ITERATIONS})' in text
    assert np.isfinite(train_cli.VALIDATION_BLOCK_S)
