"""``scara-ident train --method gp`` writes an exact GP that ``evaluate`` reads; on the
WAM's published split the documented commands score what the API and the benchmark do."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.estimator import load_model
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.learners import ExactGP

_TEST = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(Path(__file__).resolve().parent), str(_TEST / 'bag'),
                str(_TEST.parent / 'benchmarks')]
import bench_realdata  # noqa: E402  (benchmarks/bench_realdata.py)
from in_process_cli import run_cli  # noqa: E402  (test/in_process_cli.py)
from test_recording_file import REAL  # noqa: E402  (../shared/realdata)
from test_train_physical import bags, table  # noqa: E402, F401  (bags: a fixture)

WAM = REAL / 'barrett_wam.npz'

pytestmark = pytest.mark.slow  # a grid of exact GPs chooses the kernel


def test_gp_train_then_evaluate(bags: dict[str, Path], tmp_path: Path,  # noqa: F811
                                capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'gp.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--method', 'gp',
                             '--later-fraction', '0', '--out', model_path)
    assert code == 0, err
    assert 'GP (2500 samples, length ' in out  # every training sample, then every sample
    assert 'training on 2500, validating on 500' in out
    assert 'then refitted on all 3000 samples (its gp part' in out
    validation = table(out, 'joint')
    assert float(validation['mean'][3]) < 1e-2  # NMSE on the held-out blocks
    model = load_model(model_path)
    assert isinstance(model, ExactGP) and model.n_points_ == 3000
    assert int(model.metadata['train_samples']) == 3000
    assert model.joint_names == ('joint1', 'joint2', 'joint3', 'joint4')
    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err
    assert out.startswith(f'GP model {model_path} on ')
    assert float(table(out, 'joint')['mean'][1]) < 1.0


@pytest.mark.skipif(not WAM.is_file(), reason=f'no real recordings beside the clone ({WAM})')
def test_wam_documented_commands_score_what_the_api_and_the_benchmark_do(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``train FILE.npz:train --method gp`` then ``evaluate MODEL FILE.npz:test`` (and train
    from a plain table of the same rows) give the model and SMSE of ``ExactGP().fit`` on every
    training row, and the benchmark's ``gpfit`` row the same figure: on every 6th training
    row and every 3rd test row of the WAM (its interleaving, a sixth of its cost)."""
    data = np.load(WAM)
    X, Y, X_test, Y_test = (data['X_train'][::6], data['Y_train'][::6], data['X_test'][::3],
                            data['Y_test'][::3])
    split, plain = tmp_path / 'wam.npz', tmp_path / 'plain.npz'
    np.savez(split, X_train=X, Y_train=Y, X_test=X_test, Y_test=Y_test)
    np.savez(plain, q=X[:, :7], qd=X[:, 7:14], qdd=X[:, 14:], tau=Y)
    api = ExactGP().fit(X, Y).predict(X_test)
    expected = effort_errors(Y_test, api).smse
    for source, model_path in ((f'{split}:train', tmp_path / 'split_gp.npz'),
                               (plain, tmp_path / 'plain_gp.npz')):
        code, out, err = run_cli(capsys, 'train', source, '--method', 'gp', '--out',
                                 model_path)
        assert code == 0, err
        assert f'then refitted on all {len(X)} samples (its gp part' in out  # every row
        code, out, err = run_cli(capsys, 'evaluate', model_path, f'{split}:test')
        assert code == 0, err
        assert f'{len(X_test)} samples (SMSE {expected:.3g})' in out, out
        np.testing.assert_allclose(load_model(model_path).predict(X_test), api, rtol=1e-9,
                                   atol=1e-9 * float(np.abs(api).max()))
    split_rows = bench_realdata.Split('wam', tuple(f'joint {j}' for j in range(1, 8)), X, Y,
                                      X_test, Y_test, bench_realdata.every_tenth(len(X)),
                                      'a sixth', (f'{split}:train', f'{split}:test'))
    prediction, _ = bench_realdata.run_shipped_gp(split_rows, argparse.Namespace())
    assert bench_realdata.smse(Y_test, prediction) == pytest.approx(expected, rel=1e-9)
