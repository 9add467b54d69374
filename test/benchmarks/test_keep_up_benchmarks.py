"""The keep-up benchmarks run to completion in CI-sized settings (their figures are theirs)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

BENCHMARKS = Path(__file__).resolve().parents[2] / 'benchmarks'
TIMEOUT = 300.0  # s: a few seconds of graph, plus start-up and stop on a loaded machine


def run(script: str, *args: str) -> str:
    result = subprocess.run([sys.executable, str(BENCHMARKS / script), *args],
                            cwd=BENCHMARKS.parent, capture_output=True, text=True,
                            timeout=TIMEOUT)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return result.stdout


@pytest.mark.slow
def test_bench_graph_accounts_for_every_sample() -> None:
    out = run('bench_graph.py', '--seconds', '4', '--interval', '1')
    assert '**stream (simulator, identifier, recorder)**' in out
    assert '**learning (the learners)**' in out
    for method in ('ffmw', 'ffw', 'ffs'):
        assert f'| {method} | 4000 | 0 | 0 | 0 | 4000 |' in out, out
    assert 'samples not predicted or not recorded (all consumers): 0' in out


@pytest.mark.slow
def test_bench_identifier_measures_the_zero_phase_default() -> None:
    out = run('bench_identifier.py', '--samples', '2000', '--rounds', '1', '--seconds', '3',
              '--warmup', '1')
    assert '| sent / processed (stats_file) | 2000 / 2000 | equal | yes |' in out, out
    assert '| answers (predictions received) | 2000 | 2000 | yes |' in out, out
    assert 'latency' in out.lower()
