"""Comparison tables: result rows to Markdown and CSV, the paper's numbers beside ours.

Markdown cells show the median over seeds and, in brackets, the min–max range. Rows whose
data set is absent (e.g. no held-out run for a bag) show ``—``.

The paper's figures (Tables 2 and 3) are printed beside ours. The paper does not say how its
data were scaled nor in which units its MSE is, so its raw numbers cannot be compared with
ours; the normalised MSE (MSE / variance of each joint's effort) is the comparable figure,
and the *ranking* of the methods is what can be checked.
"""
from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Sequence
from pathlib import Path

from scara_ident_ros.paper.rows import HOLD, REFERENCE, ResultRow, Spread, Summary

__all__ = ['PAPER_ITERATIONS', 'PAPER_NOTE', 'PAPER_SAMPLES', 'PAPER_TABLE2', 'PAPER_TABLE3',
           'format_spread', 'format_value', 'joint_markdown', 'offline_markdown',
           'online_markdown', 'paper_ranking', 'ranking', 'ranking_text', 'read_csv',
           'write_csv']

#: Table 2 of the paper: MSE after 315 offline iterations.
PAPER_TABLE2 = {'FFMW': 8.3457e-10, 'FFW': 1.0415e-6, 'FFS': 9.1036e-6}
PAPER_ITERATIONS = 315
#: Table 3 of the paper: online error over 100 samples.
PAPER_TABLE3 = {'FFMW': 4.3038e-6, 'FFW': 1.3323e-4, 'FFS': 3.7152e-5}
PAPER_SAMPLES = 100
PAPER_NOTE = ('The paper does not state how its data were scaled (nor the units of its '
              'MSE), so its raw figures are not comparable with ours; compare the '
              'normalised MSE and the ranking of the methods.')

_DASH = '—'


def format_value(value: float | None) -> str:
    """A number with 3 significant digits, ``—`` for None or NaN."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return _DASH
    return f'{value:.3g}'


def format_spread(spread: Spread) -> str:
    """``median [min–max]``, just the median if all runs agree, ``—`` if there is none."""
    if spread.count == 0:
        return _DASH
    if spread.count == 1 or format_value(spread.low) == format_value(spread.high):
        return format_value(spread.median)
    return (f'{format_value(spread.median)} '
            f'[{format_value(spread.low)}–{format_value(spread.high)}]')


def _index(summaries: Iterable[Summary], table: str) -> tuple[list[str], dict[tuple[str, str],
                                                                            Summary]]:
    methods: list[str] = []
    index: dict[tuple[str, str], Summary] = {}
    for s in summaries:
        if s.table != table:
            continue
        if s.method not in methods:
            methods.append(s.method)
        index[(s.method, s.data)] = s
    return methods, index


def _markdown(header: Sequence[str], body: Sequence[Sequence[str]]) -> str:
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '|'.join('---' for _ in header) + '|']
    lines += ['| ' + ' | '.join(cells) + ' |' for cells in body]
    return '\n'.join(lines) + '\n'


def _cell(index: dict[tuple[str, str], Summary], method: str, data: str,
          field: str) -> str:
    s = index.get((method, data))
    return _DASH if s is None else format_spread(getattr(s, field))


def _goal_cell(s: Summary | None) -> str:
    if s is None or s.goal is None:
        return _DASH
    text = f'{s.goal_reached}/{s.n_runs}'
    if s.goal_reached:
        text += f': {format_spread(s.goal_iteration)}'
    return text


def offline_markdown(summaries: Iterable[Summary], *, train: str = 'train',
                     test: str = 'held-out', paper: bool = True) -> str:
    """The Table 2 analog.

    Columns: MSE (joint mean, physical units) and NMSE on the training and test data,
    goal reached (runs reaching it: median [range] of the iterations to it), iterations
    done, wall and CPU training time, and the paper's MSE.

    ``train``, ``test`` name the two evaluations; ``paper`` adds the paper's column.
    """
    methods, index = _index(summaries, 'offline')
    header = ['method', f'{train} MSE', f'{train} NMSE', f'{test} MSE', f'{test} NMSE',
              'goal reached: iterations', 'iterations', 'train time s', 'CPU s']
    if paper:
        header.append(f'paper MSE ({PAPER_ITERATIONS} it.)')
    body = []
    for m in methods:
        first = index.get((m, train)) or index.get((m, test))
        cells = [m, _cell(index, m, train, 'mse_mean'), _cell(index, m, train, 'nmse_mean'),
                 _cell(index, m, test, 'mse_mean'), _cell(index, m, test, 'nmse_mean'),
                 _goal_cell(first),
                 _DASH if first is None else format_spread(first.iterations),
                 _DASH if first is None else format_spread(first.train_time_s),
                 _DASH if first is None else format_spread(first.cpu_time_s)]
        if paper:
            cells.append(format_value(PAPER_TABLE2.get(m)))
        body.append(cells)
    return _markdown(header, body)


def online_markdown(summaries: Iterable[Summary], *, short: str, long: str,
                    test: str = 'held-out', paper: bool = True) -> str:
    """The Table 3 analog.

    Columns: MSE (joint mean) and NMSE over the stream's last ``short`` window (the paper's
    figure), NMSE over its last ``long`` window, MSE and NMSE on the test data (predicted
    after the stream), microseconds per learnt sample, runs diverged, and the paper's error.

    ``short``, ``long``, ``test`` are data names
    (:func:`~scara_ident_ros.paper.table3.stream_data_names`); ``paper`` adds its column.
    """
    methods, index = _index(summaries, 'online')
    header = ['method', f'{short} MSE', f'{short} NMSE', f'{long} NMSE', f'{test} MSE',
              f'{test} NMSE', 'µs/sample', 'diverged']
    if paper:
        header.append(f'paper error ({PAPER_SAMPLES} samples)')
    body = []
    for m in methods:
        first = index.get((m, short))
        per_sample = _DASH
        if first is not None and first.iterations.count and first.iterations.median > 0:
            per_sample = format_value(1e6 * first.train_time_s.median
                                      / first.iterations.median)
        cells = [m, _cell(index, m, short, 'mse_mean'), _cell(index, m, short, 'nmse_mean'),
                 _cell(index, m, long, 'nmse_mean'), _cell(index, m, test, 'mse_mean'),
                 _cell(index, m, test, 'nmse_mean'), per_sample,
                 _DASH if first is None or m in (REFERENCE, HOLD)
                 else f'{first.diverged}/{first.n_runs}']
        if paper:
            cells.append(format_value(PAPER_TABLE3.get(m)))
        body.append(cells)
    return _markdown(header, body)


def joint_markdown(summaries: Iterable[Summary], *, table: str, data: str,
                   joint_names: Sequence[str] | None = None, quantity: str = 'nmse') -> str:
    """Per-joint ``quantity`` (``'nmse'`` or ``'mse'``) of one data set, median [range]."""
    if quantity not in ('nmse', 'mse'):
        raise ValueError(f"quantity must be 'nmse' or 'mse', got {quantity!r}")
    rows = [s for s in summaries if s.table == table and s.data == data]
    if not rows:
        return ''
    n = len(rows[0].nmse)
    names = list(joint_names) if joint_names is not None else [f'joint{i + 1}'
                                                               for i in range(n)]
    body = [[s.method] + [format_spread(v) for v in getattr(s, quantity)] for s in rows]
    return _markdown(['method'] + [f'{name} {quantity.upper()}' for name in names], body)


def ranking(summaries: Iterable[Summary], *, table: str, data: str, key: str = 'nmse_mean',
            methods: Sequence[str] | None = None) -> list[str]:
    """Methods ordered by the median of ``key`` on ``data``, best (lowest) first.

    ``key`` is a `Spread` field of `Summary` (``'nmse_mean'``); ``methods`` defaults to the
    networks. Methods without a finite median are left out.
    """
    chosen = [s for s in summaries if s.table == table and s.data == data
              and (s.method in methods if methods is not None
                   else s.method not in (REFERENCE, HOLD))]
    finite = [s for s in chosen if math.isfinite(getattr(s, key).median)]
    return [s.method for s in sorted(finite, key=lambda s: getattr(s, key).median)]


def paper_ranking(table: str) -> list[str]:
    """The paper's order of the methods, best first, for ``'offline'`` or ``'online'``."""
    numbers = {'offline': PAPER_TABLE2, 'online': PAPER_TABLE3}[table]
    return sorted(numbers, key=numbers.__getitem__)


def ranking_text(summaries: Iterable[Summary], table: str,
                 criteria: Sequence[tuple[str, str, str]], labels: Sequence[str]) -> str:
    """The measured rankings held against the paper's: Markdown bullets, '' if none.

    Each of ``criteria`` (data, key, text) ranks ``labels`` by the median of ``key`` on
    ``data``; the verdict says whether the paper's ranking (and its best) holds and whether
    the first two overlap (their min–max ranges over seeds intersect).
    """
    summaries = [s for s in summaries if s.table == table]
    paper = [m for m in paper_ranking(table) if m in labels]
    index = {(s.method, s.data): s for s in summaries}
    figure = ('Table 2, MSE after 315 iterations' if table == 'offline'
              else 'Table 3, error over 100 samples')
    lines = [f"Paper's ranking ({figure}): {' < '.join(paper)}."]
    for data, key, text in criteria:
        order = ranking(summaries, table=table, data=data, key=key, methods=labels)
        if not order:
            continue
        verdict = "the paper's ranking holds" if order == paper else (
            "the paper's ranking does not hold"
            + (f', but {order[0]} is best as in the paper' if order[:1] == paper[:1] else ''))
        if len(order) > 1 and (getattr(index[(order[0], data)], key).high
                               >= getattr(index[(order[1], data)], key).low):
            verdict += (f' ({order[0]} and {order[1]} overlap: their min–max ranges over '
                        'seeds intersect)')
        lines.append(f'Measured by median {text}: {" < ".join(order)}: {verdict}.')
    return '' if len(lines) == 1 else '\n'.join(f'- {line}' for line in lines) + '\n'


def write_csv(path: str | Path, rows: Iterable[ResultRow], *,
              joint_names: Sequence[str] | None = None) -> None:
    """Write one CSV line per row (:meth:`ResultRow.to_dict` columns), floats in full.

    ``rows`` all have the same number of joints; ``joint_names`` suffix the per-joint columns.
    """
    dicts = [row.to_dict(joint_names) for row in rows]
    fields: list[str] = []
    for d in dicts:
        fields += [k for k in d if k not in fields]
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        writer = csv.DictWriter(stream, fieldnames=fields, lineterminator='\n')
        writer.writeheader()
        for d in dicts:
            writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in d.items()})


def read_csv(path: str | Path) -> list[dict[str, str]]:
    """Read a file written by `write_csv`: one dict of strings per line."""
    with open(path, newline='', encoding='utf-8') as stream:
        return list(csv.DictReader(stream))
