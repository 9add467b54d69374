"""``scara-ident tables`` / ``make_report`` on a small fake run bag: tables, figures, errors."""
from __future__ import annotations

import csv
import struct
import sys
from pathlib import Path

import pytest

from scara_ident_ros.cli import main
from scara_ident_ros.cli.tables import make_report
from scara_ident_ros.identification.recording import load_recording
from scara_ident_ros.identification.split import VALIDATION_FRACTION, block_split
from scara_ident_ros.paper.figures import figure_size_px

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'bag'))
from fake_bags import (synthetic_states, write_rosbag,  # noqa: E402  (not a package)
                       write_run_bag)
from in_process_cli import assert_one_line_error, run_cli  # test/in_process_cli.py

FAST = dict(seeds=2, iterations=4, samples=200, progress=None)
LABELS = ('FFMW', 'FFW', 'FFS')


def png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b'\x89PNG\r\n\x1a\n' and head[12:16] == b'IHDR', path
    return struct.unpack('>II', head[16:24])


def markdown_table(text: str, header_start: str) -> dict[str, list[str]]:
    """The Markdown table whose header begins with ``header_start``: first cell -> row."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    header = [c.strip() for c in lines[start].strip('|').split('|')]
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith('|'):
            break
        cells = [c.strip() for c in line.strip('|').split('|')]
        rows[cells[0]] = dict(zip(header, cells))
    return rows


@pytest.fixture(scope='module')
def run_bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """3 s at 1 kHz of a 4-joint robot, with the three identifiers' outputs."""
    states = synthetic_states(4, 3.0, seed=5)
    return write_run_bag(tmp_path_factory.mktemp('run') / 'run_bag', states), states


@pytest.fixture(scope='module')
def report(run_bag: tuple[Path, object], tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_report([run_bag[0]], tmp_path_factory.mktemp('report'), **FAST)


def test_report_has_both_tables_with_a_row_per_method(report: Path) -> None:
    text = report.read_text(encoding='utf-8')
    table2 = markdown_table(text, '| method | train MSE')
    assert set(LABELS) <= set(table2) and set(table2) <= {*LABELS, 'LS'}
    assert table2['FFMW']['paper MSE (315 it.)'] == '8.35e-10'
    assert table2['FFS']['iterations'] == '4'
    table3 = markdown_table(text, '| method | stream-last-100 MSE')
    assert list(table3) == list(LABELS)
    assert table3['FFW']['paper error (100 samples)'] == '0.000133'
    # the paper's numbers as printed, the note on scaling, the conditions and the time
    for exact in ('8.3457e-10', '1.0415e-06', '9.1036e-06', '4.3038e-06', '1.3323e-04',
                  '3.7152e-05', 'does not state how its data were scaled',
                  '## Conditions (to reproduce)', '--seeds 2 --iterations 4 --samples 200',
                  '## Time', 'total'):
        assert exact in text, exact


def test_online_figures_are_the_paired_predictions(run_bag: tuple[Path, object],
                                                   report: Path) -> None:
    _, states = run_bag
    text = report.read_text(encoding='utf-8')
    table3 = markdown_table(text, '| method | stream-last-100 MSE')
    # write_run_bag predicts every sample from the third on: recompute its last-100 error
    rows = list(csv.DictReader((report.parent / 'table3_online.csv').open()))
    assert {(r['method'], r['data']) for r in rows} == {
        (m, d) for m in LABELS for d in ('stream-last-100', 'stream-last-5000', 'stream-all')}
    for row in rows:
        assert int(row['n_samples']) == (100 if row['data'] == 'stream-last-100' else 2998)
        assert float(row['mse_mean']) > 0.0
    ffmw = next(r for r in rows if r['method'] == 'FFMW' and r['data'] == 'stream-last-100')
    assert float(ffmw['mse_mean']) == pytest.approx(float(table3['FFMW']['stream-last-100 MSE']),
                                                    rel=5e-3)
    published = markdown_table(text, '| method | published MSE')
    assert published['FFS']['paired'] == '2998' and published['FFS']['unmatched'] == '0'


def test_offline_csv_has_every_seed_and_data_set(report: Path) -> None:
    rows = list(csv.DictReader((report.parent / 'table2_offline.csv').open()))
    networks = [r for r in rows if r['method'] in LABELS]
    assert len(networks) == 3 * 2 * 2  # methods x seeds x (train, validation)
    assert {r['data'] for r in networks} == {'train', 'validation'}
    assert {r['seed'] for r in networks} == {'0', '1'}
    assert all(r['n_samples'] == '200' for r in networks if r['data'] == 'train')
    assert {'mse_joint1', 'nmse_joint4'} <= set(rows[0])


def test_tables_validates_on_the_blocks_train_validates_on(report: Path,
                                                            run_bag: tuple[Path, object]) -> None:
    rows = list(csv.DictReader((report.parent / 'table2_offline.csv').open()))
    _, validation = block_split(load_recording(run_bag[0]).samples.data, VALIDATION_FRACTION)
    assert {int(r['n_samples']) for r in rows if r['data'] == 'validation'} == {len(validation)}
    assert 0 < len(validation) <= 1000  # one block of 1 s of the 3 s run


def test_figures_are_pngs_of_the_expected_size(report: Path) -> None:
    out = report.parent
    for m in ('ffmw', 'ffw', 'ffs'):
        for kind in ('online', 'offline'):
            assert png_size(out / f'fig_torque_{kind}_{m}.png') == figure_size_px('torque', 4)
            assert f'(fig_torque_{kind}_{m}.png)' in report.read_text(encoding='utf-8')
    assert png_size(out / 'fig14_training_mse.png') == figure_size_px('training')
    assert png_size(out / 'fig15_online_error.png') == figure_size_px('online')


def test_cli_with_a_held_out_run_and_two_joints(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    run = write_run_bag(tmp_path / 'run', synthetic_states(2, 2.0, seed=1),
                        methods=('ffmw', 'ffs'))
    other = write_rosbag(tmp_path / 'other', synthetic_states(2, 1.0, seed=2),
                         storage='sqlite3')
    out = tmp_path / 'report'
    code = main(['tables', str(run), str(other), '--out', str(out), '--methods', 'ffmw',
                 'ffs', '--seeds', '1', '--iterations', '3', '--samples', '100'])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert f'report: {out / "report.md"}' in captured.out
    assert 'offline FFMW seed 0' in captured.err  # progress on stderr
    text = (out / 'report.md').read_text(encoding='utf-8')
    table2 = markdown_table(text, '| method | train MSE')
    assert list(table2) == ['FFMW', 'FFS']  # no LS reference for 2 joints
    assert table2['FFS']['held-out NMSE'] != '—'
    assert '`held-out` (' in text and 'the first held-out run' in text
    assert png_size(out / 'fig_torque_online_ffs.png') == figure_size_px('torque', 2)
    assert not (out / 'fig_torque_online_ffw.png').exists()


def test_a_bag_without_online_topics_gives_the_offline_part(tmp_path: Path) -> None:
    bag = write_rosbag(tmp_path / 'plain', synthetic_states(2, 2.0), storage='mcap')
    report = make_report([bag], tmp_path / 'out', methods=['ffw'], **FAST)
    text = report.read_text(encoding='utf-8')
    assert 'No online predictions in the bag for FFW (`/ffw/identified_torque`)' in text
    assert list(markdown_table(text, '| method | train MSE')) == ['FFW']
    assert not (tmp_path / 'out' / 'fig15_online_error.png').exists()
    rows = list(csv.DictReader((tmp_path / 'out' / 'table3_online.csv').open()))
    assert rows == []


def test_time_budget_keeps_whole_rounds_of_seeds(tmp_path: Path) -> None:
    bag = write_rosbag(tmp_path / 'plain', synthetic_states(2, 2.0), storage='mcap')
    options = {**FAST, 'seeds': 3, 'time_budget_s': 1e-6}
    report = make_report([bag], tmp_path / 'out', methods=['ffmw', 'ffs'], **options)
    text = report.read_text(encoding='utf-8')
    assert 'Seeds 1, 2 were asked for but left out' in text
    rows = list(csv.DictReader((tmp_path / 'out' / 'table2_offline.csv').open()))
    assert {(r['method'], r['seed']) for r in rows} == {('FFMW', '0'), ('FFS', '0')}
    assert '--seeds 1' in text


def test_bad_inputs_give_one_line(run_bag: tuple[Path, object], tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'out'
    assert_one_line_error(*run_cli(capsys, 'tables', tmp_path / 'missing', '--out', out),
                          r'missing: does not exist')
    few = write_rosbag(tmp_path / 'few', synthetic_states(2, 0.005))
    assert_one_line_error(*run_cli(capsys, 'tables', few, '--out', out), r'few.*need at least 20')
    # a run of one block of 1 s: too short for the validation split of train and tables
    short = write_rosbag(tmp_path / 'short', synthetic_states(2, 1.0))
    assert_one_line_error(*run_cli(capsys, 'tables', short, '--out', out),
                          r'short.*fill 1 block of 1 s.*--validation-block')
    # a held-out run without the analysed run's joints
    other = write_rosbag(tmp_path / 'other', synthetic_states(2, 0.5, prefix='axis'))
    assert_one_line_error(*run_cli(capsys, 'tables', run_bag[0], other, '--out', out,
                                   '--seeds', '1', '--iterations', '1'),
                          r'other.*joint1.*joint names in the messages: axis1, axis2')
    assert_one_line_error(*run_cli(capsys, 'tables', run_bag[0], '--out', out, '--seeds', '0'),
                          r'--seeds >= 1')
    (tmp_path / 'file').write_text('')
    assert_one_line_error(*run_cli(capsys, 'tables', run_bag[0], '--out', tmp_path / 'file'),
                          r'not a directory')
    assert not out.exists()  # nothing written on a bad input


def test_help_explains(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(['tables', '--help'])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for word in ('Table 2', 'Table 3', 'identified_torque', 'Time', '--time-budget'):
        assert word in text, word


def test_run_skips_the_report_of_a_run_too_short_to_validate_on(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from scara_ident_ros.cli.run import _report

    bag = write_rosbag(tmp_path / 'short', synthetic_states(2, 1.0))
    _report(bag, tmp_path / 'report', ['ffs'], interrupted=False)
    assert 'scara-ident run: no report: 0.999 s of samples fill 1 block' in capsys.readouterr().out
    assert not (tmp_path / 'report').exists()
