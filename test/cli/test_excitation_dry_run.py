"""``scara-ident excitation --dry-run``: the planned trajectory and its figure, checked
against the limits, nothing moved; refusals in one line with exit status 2."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.cli import main
from scara_ident_ros.excitation import load_motion_limits

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / 'urdf' / 'scara.urdf'


def test_dry_run_writes_a_trajectory_within_the_limits_and_a_figure(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'plan'
    assert main(['excitation', '--dry-run', '--urdf', str(URDF), '--seconds', '8',
                 '--start', '0.5,-0.5,0.05,2', '--seed', '3', '--output', str(out)]) == 0
    printed = capsys.readouterr().out
    assert 'within the limits with margins' in printed
    table = np.loadtxt(out / 'excitation.csv', delimiter=',', skiprows=1)
    header = (out / 'excitation.csv').read_text().splitlines()[0].split(',')
    assert header[:2] == ['t', 'q_joint1'] and len(header) == 13 == table.shape[1]
    t, q, qd, qdd = table[:, 0], table[:, 1:5], table[:, 5:9], table[:, 9:13]
    np.testing.assert_allclose(np.diff(t), 0.01, atol=1e-9)
    assert t[-1] > 8.0
    np.testing.assert_allclose(q[0], [0.5, -0.5, 0.05, 2.0])
    margined = load_motion_limits(urdf_file=str(URDF)).with_margins(0.1, 0.5, 0.5)
    assert margined.violations(q, qd, qdd, position_hull=q[0]) == []
    assert np.all(qd[0] == 0) and np.all(qd[-1] == 0)
    png = (out / 'excitation.png').read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 20_000


def test_dry_run_optimize_plans_the_better_conditioned_motion(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'plan'
    assert main(['excitation', '--dry-run', '--urdf', str(URDF), '--seconds', '10',
                 '--optimize', '--harmonics', '3', '--period', '5', '--max-seconds', '5',
                 '--output', str(out)]) == 0
    printed = capsys.readouterr().out
    assert 'optimised 3 harmonics of a 5 s period' in printed
    line = next(row for row in printed.splitlines() if 'over 10 s of excitation' in row)
    ours, theirs = (float(line.split(name)[1].split()[0].rstrip(','))
                    for name in ('optimised', 'random sequence'))
    assert ours < theirs
    table = np.loadtxt(out / 'excitation.csv', delimiter=',', skiprows=1)
    q, qd, qdd = table[:, 1:5], table[:, 5:9], table[:, 9:13]
    margined = load_motion_limits(urdf_file=str(URDF)).with_margins(0.1, 0.5, 0.5)
    assert margined.violations(q, qd, qdd, position_hull=q[0]) == []
    assert np.all(qd[0] == 0) and np.all(qd[-1] == 0)


@pytest.mark.parametrize('args, message', [
    (['--start', '0,0,0.3,0'], 'the start is outside the limits: joint3 = 0.3'),
    (['--joint-names', 'joint1,wrist'], 'no joint limits for wrist'),
    (['--start', '0,0'], '--start needs 4 positions'),
    (['--optimize', '--harmonics', '0'], '--harmonics must be >= 1'),
])
def test_refusals_are_one_line_and_exit_2(args: list[str], message: str,
                                          tmp_path: Path) -> None:
    out = subprocess.run([sys.executable, '-m', 'scara_ident_ros.cli', 'excitation',
                          '--dry-run', '--urdf', str(URDF), '--output', str(tmp_path / 'o'),
                          *args], capture_output=True, text=True, timeout=120, check=False)
    assert out.returncode == 2
    assert out.stderr.count('\n') == 1 and message in out.stderr, out.stderr
    assert not (tmp_path / 'o').exists()
