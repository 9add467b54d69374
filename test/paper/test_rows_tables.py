"""Result rows, their summaries over seeds, Markdown and CSV."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.paper.rows import ResultRow, Spread, summarise
from scara_ident_ros.paper.tables import (PAPER_TABLE2, format_spread, joint_markdown,
                                          offline_markdown, online_markdown, paper_ranking,
                                          ranking, ranking_text, read_csv, write_csv)


def _row(method: str, seed: int | None, data: str, nmse: float, **extra: object) -> ResultRow:
    return ResultRow(table='offline', method=method, seed=seed, data=data, n_samples=10,
                     mse=(nmse * 2, nmse * 4), nmse=(nmse, nmse), mse_mean=nmse * 3,
                     nmse_mean=nmse, **extra)  # type: ignore[arg-type]


def test_from_stats_copies_the_error_statistics() -> None:
    Y = np.array([[1.0, 2.0], [3.0, 5.0], [2.0, 2.0]])
    stats = effort_errors(Y, Y * 1.1)
    row = ResultRow.from_stats(stats, table='online', method='FFS', seed=3, data='held-out',
                               iterations=7)
    assert row.mse == tuple(stats.mse) and row.nmse == tuple(stats.nmse)
    assert row.mse_mean == stats.mse_total and row.nmse_mean == stats.nmse_total
    assert row.n_samples == 3 and row.iterations == 7 and not row.goal_reached


def test_spread_ignores_missing_values() -> None:
    assert Spread.of([3.0, None, 1.0, math.nan, 2.0]) == Spread(2.0, 1.0, 3.0, 3)
    assert Spread.of([]).count == 0 and math.isnan(Spread.of([None]).median)
    assert format_spread(Spread.of([1.0, 2.0, 30.0])) == '2 [1–30]'
    assert format_spread(Spread.of([0.5])) == '0.5'
    assert format_spread(Spread.of([])) == '—'


def test_summarise_groups_by_method_and_data_over_seeds() -> None:
    rows = [_row('FFMW', s, d, v, goal=1e-5, goal_iteration=g, iterations=315,
                 train_time_s=1.0 + s)
            for s, (v, g) in enumerate([(1e-3, 10), (2e-3, None), (3e-3, 30)])
            for d in ('train', 'held-out')]
    rows += [_row('LS', None, d, 1e-20) for d in ('train', 'held-out')]
    summaries = summarise(rows)
    assert [(s.method, s.data) for s in summaries] == [
        ('FFMW', 'train'), ('FFMW', 'held-out'), ('LS', 'train'), ('LS', 'held-out')]
    ffmw = summaries[0]
    assert ffmw.n_runs == 3 and ffmw.goal_reached == 2
    assert ffmw.nmse_mean == Spread(2e-3, 1e-3, 3e-3, 3)
    assert ffmw.goal_iteration == Spread(20.0, 10.0, 30.0, 2)
    assert ffmw.train_time_s.median == 2.0
    text = offline_markdown(summaries)
    lines = text.splitlines()
    assert lines[0].startswith('| method | train MSE')
    assert lines[2].startswith('| FFMW | 0.006 [0.003–0.009] | 0.002 [0.001–0.003]')
    assert '| 2/3: 20 [10–30] | 315 |' in lines[2]
    assert f'{PAPER_TABLE2["FFMW"]:.3g}' in lines[2]
    assert lines[3].startswith('| LS |')
    assert 'joint2 NMSE' in joint_markdown(summaries, table='offline', data='held-out')


def test_ranking_and_paper_ranking() -> None:
    rows = [_row(m, 0, 'held-out', v) for m, v in (('FFMW', 3.0), ('FFW', 1.0), ('FFS', 2.0),
                                                    ('LS', 0.0))]
    summaries = summarise(rows)
    assert ranking(summaries, table='offline', data='held-out') == ['FFW', 'FFS', 'FFMW']
    assert paper_ranking('offline') == ['FFMW', 'FFW', 'FFS']
    assert paper_ranking('online') == ['FFMW', 'FFS', 'FFW']


def test_ranking_text_gives_one_verdict_per_criterion() -> None:
    rows = [_row(m, s, d, v * (1 + s)) for s in (0, 1)
            for d, values in (('train', (1.0, 2.0, 3.0)), ('held-out', (1.0, 5.0, 1.5)))
            for m, v in zip(('FFMW', 'FFW', 'FFS'), values)]
    text = ranking_text(summarise(rows), 'offline', [('train', 'nmse_mean', 'train NMSE'),
                                                     ('held-out', 'nmse_mean', 'NMSE')],
                        ['FFMW', 'FFW', 'FFS'])
    lines = text.splitlines()
    assert lines[0] == "- Paper's ranking (Table 2, MSE after 315 iterations): FFMW < FFW < FFS."
    assert lines[1] == ("- Measured by median train NMSE: FFMW < FFW < FFS: the paper's ranking "
                        'holds (FFMW and FFW overlap: their min–max ranges over seeds '
                        'intersect).')
    assert lines[2] == ("- Measured by median NMSE: FFMW < FFS < FFW: the paper's ranking does "
                        'not hold, but FFMW is best as in the paper (FFMW and FFS overlap: '
                        'their min–max ranges over seeds intersect).')
    assert ranking_text(summarise(rows), 'online', [('none', 'nmse_mean', 'x')], ['FFW']) == ''


def test_online_markdown_has_the_paper_column() -> None:
    rows = [ResultRow(table='online', method='FFW', seed=0, data=d, n_samples=100, mse=(1.0,),
                      nmse=(0.1,), mse_mean=1.0, nmse_mean=0.1, iterations=1000,
                      train_time_s=0.02) for d in ('stream-last-100', 'stream-last-5000')]
    text = online_markdown(summarise(rows), short='stream-last-100', long='stream-last-5000')
    assert '| FFW | 1 | 0.1 | 0.1 | — | — | 20 | 0/1 | 0.000133 |' in text


def test_csv_round_trip_keeps_full_precision(tmp_path: Path) -> None:
    rows = [_row('FFS', 1, 'train', 1 / 3, goal=1e-5, goal_iteration=None),
            _row('LS', None, 'train', 1e-30)]
    path = tmp_path / 'table.csv'
    write_csv(path, rows, joint_names=['a', 'b'])
    back = read_csv(path)
    assert [r['method'] for r in back] == ['FFS', 'LS']
    assert float(back[0]['nmse_a']) == 1 / 3 and back[0]['goal_reached'] == 'False'
    assert back[1]['seed'] == '' and back[1]['goal'] == '' and float(back[1]['mse_b']) == 4e-30
    with pytest.raises(ValueError, match='joint names'):
        rows[0].to_dict(['only-one'])
