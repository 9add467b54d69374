"""``scara-ident compare --quick``: both tables, CSVs, search results, conditions."""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest

from scara_ident_ros.cli import main
from scara_ident_ros.paper.tables import read_csv

NETWORKS = ('FFMW', 'FFW', 'FFS')


@pytest.fixture(scope='module')
def compare(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, str, Path]:
    out = tmp_path_factory.mktemp('compare')
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        status = main(['compare', '--quick', '--out', str(out)])
    return status, stdout.getvalue(), out


def _first_column(text: str, heading: str) -> list[str]:
    """First-column cells of the first table after ``heading``."""
    lines = text.split(heading, 1)[1].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith('| method'))
    cells = []
    for line in lines[start + 2:]:
        if not line.startswith('|'):
            break
        cells.append(line.split('|')[1].strip())
    return cells


def test_prints_both_tables_with_every_method_and_the_reference(
        compare: tuple[int, str, Path]) -> None:
    status, text, _ = compare
    assert status == 0
    assert _first_column(text, '## Table 2 analog') == [*NETWORKS, 'LS']
    assert _first_column(text, '## Table 3 analog') == [*NETWORKS, 'LS', 'hold']
    assert '8.35e-10' in text and '4.3e-06' in text  # the paper's numbers beside ours
    assert 'not comparable' in text and 'ranking' in text


def test_csvs_have_a_row_per_method(compare: tuple[int, str, Path]) -> None:
    _, _, out = compare
    for name, data in (('table2.csv', {'train', 'held-out'}),
                       ('table3.csv', {'stream-last-100', 'stream-last-1000', 'held-out'})):
        rows = read_csv(out / name)
        baseline = {'hold'} if name == 'table3.csv' else set()
        assert {r['method'] for r in rows} == {*NETWORKS, 'LS', *baseline}
        assert {r['data'] for r in rows} == data
        for row in rows:  # nmse_mean is the mean of the per-joint NMSE
            per_joint = [float(row[f'nmse_joint{j}']) for j in range(1, 5)]
            assert float(row['nmse_mean']) == pytest.approx(sum(per_joint) / 4, rel=1e-12)
        ls = [r for r in rows if r['method'] == 'LS' and r['data'] == 'held-out']
        assert len(ls) == 1
    # offline LS on noise-free data with the true q'': exact to rounding
    ls = [r for r in read_csv(out / 'table2.csv') if r['method'] == 'LS']
    assert all(float(r['nmse_mean']) < 1e-18 for r in ls)


def test_learning_curves_of_every_method_and_trainer(compare: tuple[int, str, Path]) -> None:
    status, text, out = compare
    section = text.split('## Learning curves', 1)[1]
    labels = [line.split('|')[1].strip() for line in section.splitlines()
              if line.startswith('| ') and not line.startswith('| method')]
    assert labels == ['LS', 'RLS', *(f'{m} {t}' for t in ('lm', 'bp') for m in NETWORKS)]
    assert (out / 'fig_learning_curves.png').read_bytes()[:4] == b'\x89PNG'


def test_writes_markdown_search_and_conditions(compare: tuple[int, str, Path]) -> None:
    _, text, out = compare
    assert (out / 'tables.md').read_text(encoding='utf-8') == text
    search = read_csv(out / 'search.csv')
    assert {r['method'] for r in search} == set(NETWORKS)
    assert sum(r['chosen'] == 'True' for r in search) == 3
    conditions = json.loads((out / 'conditions.json').read_text())
    assert conditions['seeds'] == [0, 1] and conditions['iterations'] == 5
    assert set(conditions['hyperparameters']) == set(NETWORKS)
    assert conditions['data']['online stream']['samples'] > 0
    assert 'numpy' in conditions['versions']


def test_bad_options_are_one_line_errors(capsys: pytest.CaptureFixture[str],
                                         tmp_path: Path) -> None:
    assert main(['compare', '--quick', '--train-seed', '3', '--test-seed', '3',
                 '--out', str(tmp_path)]) == 2
    assert 'must differ' in capsys.readouterr().err
