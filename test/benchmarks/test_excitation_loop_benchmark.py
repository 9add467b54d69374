"""benchmarks/bench_excitation_loop.py --in-process at CI size runs to completion and prints
its tables (the figures come from its full size, in benchmarks/excitation_loop.md)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def test_bench_excitation_loop_in_process_runs_at_ci_size() -> None:
    env = {**os.environ, 'PYTHONPATH': str(ROOT)}
    out = subprocess.run(
        [sys.executable, str(ROOT / 'benchmarks' / 'bench_excitation_loop.py'), '--in-process',
         '--seconds', '3', '--seeds', '1', '--workers', '1', '--held-out', '1', '2',
         '--settings', '0.1:0.5:0.5'],
        capture_output=True, text=True, env=env, timeout=600, check=False)
    assert out.returncode == 0, out.stderr
    for label in ('scara_sim sequence', 'loop, margin 0.1, scales 0.5/0.5'):
        row = re.search(rf'^\| {re.escape(label)} \(FFS lm\) \| ([0-9.e+-]+) ', out.stdout,
                        re.MULTILINE)
        assert row is not None, out.stdout
        assert float(row.group(1)) > 0.0  # a held-out NMSE after 3 s of stream
    # the loop's stream: 0.5 s of its 3 s at rest before the plan's origin (start_delay)
    rest = re.search(r'^\| loop, margin 0\.1, scales 0\.5/0\.5 \(FFS lm\) \|.*\| '
                     r'([0-9.]+) % \|$', out.stdout, re.MULTILINE)
    assert rest is not None, out.stdout
    assert 15.0 <= float(rest.group(1)) <= 25.0
    assert re.search(r'^\| loop, margin 0\.1.*\| 1 \|$', out.stdout, re.MULTILINE), out.stdout
