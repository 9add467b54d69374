"""``scara-ident compare --recording``: the comparison on a recording, held out by blocks."""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.cli import main
from scara_ident_ros.identification.recording import load_recording
from scara_ident_ros.identification.split import block_split
from scara_ident_ros.paper.tables import read_csv

NETWORKS = ('FFMW', 'FFW', 'FFS')
RATE_HZ = 100.0


def linear_arm_table(path: Path, seconds: float = 15.0) -> Path:
    """A 2-joint table (t, q, q', q'', τ, names) whose effort is exactly linear in the
    reference's features, so linear least squares must predict the held-out blocks to
    rounding error."""
    t = np.arange(round(seconds * RATE_HZ)) / RATE_HZ
    amp = np.array([[0.8, 0.3], [0.5, 0.4]])  # joint x harmonic
    freq = np.array([[1.3, 3.1], [0.7, 2.3]])  # rad/s
    phase = np.array([[0.0, 1.0], [2.0, 0.0]])
    arg = freq[None] * t[:, None, None] + phase[None]  # (N, joint, harmonic)
    q = (amp * np.sin(arg)).sum(axis=2)
    qd = (amp * freq * np.cos(arg)).sum(axis=2)
    qdd = -(amp * freq ** 2 * np.sin(arg)).sum(axis=2)
    tau = 2.0 * qdd + 0.5 * qd + 3.0 * np.sin(q) + 0.2 * np.tanh(qd / 0.05) + 0.1
    np.savez(path, t=t, q=q, qd=qd, qdd=qdd, tau=tau, names=np.array(['shoulder', 'elbow']))
    return path


@pytest.fixture(scope='module')
def compared(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, str, Path, Path]:
    tmp = tmp_path_factory.mktemp('compare_recording')
    table = linear_arm_table(tmp / 'arm.npz')
    out = tmp / 'out'
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        status = main(['compare', '--quick', '--recording', str(table), '--out', str(out),
                       '--validation-block', '0.5'])
    return status, stdout.getvalue(), out, table


def test_held_out_is_the_validation_blocks_of_train(
        compared: tuple[int, str, Path, Path]) -> None:
    status, text, out, table = compared
    assert status == 0
    assert 'on a recording' in text and 'shoulder, elbow' in text
    samples = load_recording(table).samples.data
    train, held_out = block_split(samples, 0.2, block_s=0.5, seed=0)
    conditions = json.loads((out / 'conditions.json').read_text())
    data = conditions['data']
    assert data['offline held-out']['samples'] == data['online held-out']['samples'] \
        == len(held_out)
    assert data['online stream']['samples'] == data['offline training pool']['samples'] \
        == len(train)
    assert data['offline training (LM)']['samples'] == 200  # --quick
    assert conditions['source']['kind'] == 'recording'
    assert conditions['network'] == '6-40-2'


def test_every_method_is_scored_on_held_out_blocks_and_the_linear_reference_is_exact(
        compared: tuple[int, str, Path, Path]) -> None:
    _, _, out, _ = compared
    for name, baseline in (('table2.csv', set()), ('table3.csv', {'hold'})):
        rows = read_csv(out / name)
        assert {r['method'] for r in rows} == {*NETWORKS, 'LS', *baseline}
        held_out = [r for r in rows if r['data'] == 'held-out']
        assert {r['method'] for r in held_out} == {*NETWORKS, 'LS'}
        ls, = (r for r in held_out if r['method'] == 'LS')
        assert float(ls['nmse_mean']) < 1e-12  # the effort is linear in its features
        for row in held_out:
            assert np.isfinite(float(row['nmse_mean']))


def test_refusals() -> None:
    with contextlib.redirect_stderr(io.StringIO()) as err:
        assert main(['compare', '--quick', '--joints', 'a']) == 2
    assert '--recording' in err.getvalue()
    with contextlib.redirect_stderr(io.StringIO()) as err:
        assert main(['compare', '--quick', '--recording', 'nowhere.npz']) == 2
    assert 'does not exist' in err.getvalue()
