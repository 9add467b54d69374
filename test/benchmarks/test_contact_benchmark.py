"""benchmarks/bench_contact.py at CI size runs to completion and prints its table (the
figures come from its full size, in benchmarks/contact.md)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def test_bench_contact_runs_at_ci_size() -> None:
    env = {**os.environ, 'PYTHONPATH': str(ROOT)}
    out = subprocess.run(
        [sys.executable, str(ROOT / 'benchmarks' / 'bench_contact.py'), '--seconds', '20',
         '--clean-seconds', '5', '--pulse-seconds', '5', '--sigmas', '8'],
        capture_output=True, text=True, env=env, timeout=600, check=False)
    assert out.returncode == 0, out.stderr
    row = re.search(r'^\| 8 \| (\d+)/(\d+) .*\| (\d+)/(\d+) ', out.stdout, re.MULTILINE)
    assert row is not None, out.stdout
    detected, pulses, base_detected, base_pulses = map(int, row.groups())
    assert pulses == base_pulses >= 2 and 0 <= detected <= pulses
    assert base_detected <= base_pulses
