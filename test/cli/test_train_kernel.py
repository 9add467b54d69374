"""``scara-ident train --method kernel`` writes a sparse-spectrum GP that ``evaluate`` reads."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from scara_ident_ros.estimator import load_model
from scara_ident_ros.learners import SparseSpectrumGP

sys.path.insert(0, str(Path(__file__).resolve().parent))
from in_process_cli import run_cli  # noqa: E402  (test/in_process_cli.py)
from test_train_physical import (bags, scara_states, table,  # noqa: E402, F401  (bags: a
                                 write_rosbag)  # fixture; write_rosbag: test/bag/fake_bags)

pytestmark = pytest.mark.slow  # an exact GP on the training samples chooses the kernel


def test_kernel_train_then_evaluate(bags: dict[str, Path], tmp_path: Path,  # noqa: F811
                                    capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'kernel.npz'
    # 3 s: an exact GP on 1200 samples chooses the kernel, not on 1500 of 6 s (half the time)
    train = write_rosbag(tmp_path / 'train', scara_states(3.0, seed=1), storage='mcap')
    code, out, err = run_cli(capsys, 'train', train, '--method', 'kernel',
                             '--later-fraction', '0', '--out', model_path)
    assert code == 0, err
    assert 'KERNEL (500 random features) fitted in ' in out
    assert 'training on 1000, validating on 500' in out  # every training sample
    validation = table(out, 'joint')
    assert float(validation['mean'][3]) < 1e-2  # NMSE on the held-out blocks
    model = load_model(model_path)
    assert isinstance(model, SparseSpectrumGP)
    assert model.joint_names == ('joint1', 'joint2', 'joint3', 'joint4')
    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err
    assert out.startswith(f'KERNEL model {model_path} on ')
    # another run, wider than the training motion: a kernel does not extrapolate well
    assert float(table(out, 'joint')['mean'][1]) < 1.0
