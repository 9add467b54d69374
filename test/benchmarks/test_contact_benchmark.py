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
         '--clean-seconds', '5', '--pulse-seconds', '5', '--bounds', '1'],
        capture_output=True, text=True, env=env, timeout=600, check=False)
    assert out.returncode == 0, out.stderr
    # 20 s of stream hold out too few blocks to arm on them: the row says why, and flags
    # nothing
    row = re.search(r'^\| held-out \(before\), bound 1/h \| no \((.*)\) \|.*\| (\d+)/(\d+) \|',
                    out.stdout, re.MULTILINE)
    assert row is not None, out.stdout
    why, detected, pulses = row.group(1), int(row.group(2)), int(row.group(3))
    assert 'independent' in why and detected == 0 and pulses >= 2
    # the a-priori residuals, the default, give a row of the same pulses, armed or not
    row = re.search(r'^\| a-priori [0-9.]+ s, bound 1/h \| (yes|no \(.*\)) \|.*\| (\d+)/(\d+) \|',
                    out.stdout, re.MULTILINE)
    assert row is not None and int(row.group(3)) == pulses, out.stdout
    # the node's calibrations while it learns (every 10 s of stream): none armed on the
    # held-out segments; each a-priori calibration says what it found
    assert re.search(r'^Calibrated on the held-out residuals: \*\*Not armed\*\* in 20 s '
                     r'\(10 s: .*; 20 s: .*\)\.$', out.stdout, re.MULTILINE), out.stdout
    assert re.search(r'^Calibrated on the a-priori residuals: \*\*(Armed at|Not armed).*'
                     r'\(10 s: .*; 20 s: .*\)\.$', out.stdout, re.MULTILINE), out.stdout
    before = re.search(r'^\| before: 12 x .*\| (\d+)/(\d+) \|', out.stdout, re.MULTILINE)
    assert before is not None and int(before.group(2)) == pulses
    # each calibration's room per joint: four 'clean < pulse' pairs, or why there are none
    rooms = re.findall(r'^- (a-priori|held-out) .*: (not calibrated|(?:[0-9.e+-]+ < [0-9.e+inf-]+'
                       r'(?: \(threshold [0-9.e+-]+\))?(?:; |$)){4})$', out.stdout, re.MULTILINE)
    assert [on for on, _ in rooms] == ['a-priori', 'held-out'], out.stdout
