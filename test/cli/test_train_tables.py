"""``scara-ident train`` and ``evaluate`` on recordings that are not rosbag2 bags: an npz of
the SCARA without velocities (physical model from its URDF, q' derived), a table without
time with its splits, URDF joints missing from the recording held fixed."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics.physical_model import PhysicalModel

sys.path.insert(0, str(Path(__file__).resolve().parent))
from in_process_cli import assert_one_line_error, run_cli  # noqa: E402
from test_train_physical import COULOMB, NAMES, URDF, VISCOUS, scara_states, table  # noqa: E402


@pytest.fixture(scope='module')
def npz(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """6 s of the SCARA at 1 kHz as t, q, tau, names: no velocity."""
    states = scara_states(6.0, seed=1, rate_hz=1000.0)
    path = tmp_path_factory.mktemp('tables') / 'scara.npz'
    t = (states.stamp_ns - states.stamp_ns[0]) * 1e-9
    np.savez(path, t=t, q=states.position, tau=states.effort, names=np.array(NAMES))
    return path


def test_physical_from_an_npz_without_velocity(npz: Path, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'physical.npz'
    code, out, err = run_cli(capsys, 'train', npz, '--method', 'physical', '--urdf', URDF,
                             '--coulomb', 'tanh', '--out', model_path)
    assert code == 0, err
    assert "q' derived from q for joint1, joint2, joint3, joint4" in out
    assert '1000 Hz (median step' in out
    model = PhysicalModel.load(model_path)
    # the derived q' and the q'' estimated from it identify the friction within 3 %
    np.testing.assert_allclose(model.viscous, VISCOUS, rtol=0.03, atol=0.02)
    np.testing.assert_allclose(model.coulomb_friction, COULOMB, rtol=0.03, atol=0.02)
    code, out, err = run_cli(capsys, 'evaluate', model_path, npz)
    assert code == 0, err
    assert float(table(out, 'joint | scara.npz MSE')['mean'][1]) < 1e-3


def test_urdf_joints_not_recorded_are_held_fixed(npz: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    data = dict(np.load(npz))
    three = tmp_path / 'three.npz'
    np.savez(three, t=data['t'], q=data['q'][:, :3], tau=data['tau'][:, :3],
             names=np.array(NAMES[:3]))
    code, out, err = run_cli(capsys, 'train', three, '--method', 'physical', '--urdf', URDF,
                             '--coulomb', 'tanh', '--out', tmp_path / 'p.npz')
    assert code == 0, err
    assert 'joints not in the recording, held fixed at 0: joint4' in out
    assert PhysicalModel.load(tmp_path / 'p.npz').joint_names == NAMES[:3]


def test_a_table_without_time_trains_on_one_split_and_evaluates_on_another(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    states = scara_states(4.0, seed=3, rate_hz=500.0)
    q, qd, tau = states.position, states.velocity, states.effort
    qdd = np.gradient(qd, 1 / 500.0, axis=0)
    X, Y = np.hstack([q, qd, qdd]), tau
    path = tmp_path / 'arm.npz'
    np.savez(path, X_train=X[:1500], Y_train=Y[:1500], X_test=X[1500:], Y_test=Y[1500:])
    code, out, err = run_cli(capsys, 'train', path, '--method', 'ffs', '--out',
                             tmp_path / 'm.npz')
    assert_one_line_error(code, out, err, r'a split named: .*arm\.npz:test, .*arm\.npz:train')
    code, out, err = run_cli(capsys, 'train', f'{path}:train', '--method', 'ffs',
                             '--iterations', '3', '--validation-fraction', '0',
                             '--out', tmp_path / 'm.npz')
    assert code == 0, err
    assert '1500 samples of 4 joints' in out and "rows without time, in order; q'' as given" in out
    code, out, err = run_cli(capsys, 'evaluate', tmp_path / 'm.npz', f'{path}:test')
    assert code == 0, err
    assert 'test: 500 samples' in out or '500 samples' in out
