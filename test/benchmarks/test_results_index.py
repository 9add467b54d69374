"""docs/results.md's verdict table and benchmarks/README.md's index point at files that exist:
every figure is traceable to the benchmark output that holds it."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = ['docs/results.md', 'benchmarks/README.md', 'README.md']
LINK = re.compile(r'\]\(([^)#\s]+)(?:#[^)]*)?\)')


@pytest.mark.parametrize('page', PAGES)
def test_every_relative_link_resolves(page: str) -> None:
    path = ROOT / page
    links = [link for link in LINK.findall(path.read_text(encoding='utf-8'))
             if '://' not in link]
    assert links, page
    missing = [link for link in links if not (path.parent / link).exists()]
    assert missing == [], (page, missing)


def verdict_rows() -> list[list[str]]:
    """The rows of the verdict tables: the section's tables, header and rule left out."""
    text = (ROOT / 'docs' / 'results.md').read_text(encoding='utf-8')
    section = text.split('## Verdict: where the project stands', 1)[1].split('\n## ', 1)[0]
    rows = [[cell.strip() for cell in line.strip().strip('|').split('|')]
            for line in section.splitlines() if line.startswith('| ')]
    return [row for row in rows if row[0] != 'data set']


def test_each_verdict_row_names_its_figure_its_baseline_and_its_source() -> None:
    rows = verdict_rows()
    data_sets = {row[0].split(' ')[0].split(',')[0] for row in rows}
    assert {'WAM', 'TIAGo', 'TX40', 'SARCOS', 'SCARA', 'UR5', 'Panda'} <= data_sets
    for row in rows:
        assert len(row) == 6, row  # data set, method, figure, baseline, verdict, source
        assert all(row), row
        source = row[5]
        # a benchmark output file (linked), a script, or the issue the figure comes from
        assert '.md' in source or '.py' in source or 'issue' in source, row
