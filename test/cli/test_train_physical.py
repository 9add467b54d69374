"""``scara-ident train --method physical|hybrid --urdf`` and ``evaluate`` of every kind."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.learners.hybrid_model import HybridModel
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.nn import FeedForwardNet

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'bag'))
from fake_bags import States, write_rosbag  # noqa: E402  (not a package)
from in_process_cli import run_cli  # test/in_process_cli.py

URDF = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'
NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
VISCOUS = np.array([3.0, 1.5, 20.0, 0.05])    # N·m·s/rad, N·s/m
COULOMB = np.array([6.0, 3.0, 15.0, 0.5])     # N·m, N
EPS = 0.05                                    # rad/s, m/s: the CLI's default tanh


def scara_states(seconds: float, *, seed: int, rate_hz: float = 500.0) -> States:
    """Smooth motion of the URDF's SCARA within its limits, efforts of its URDF plus friction.

    Every harmonic's period divides 2 s, so any 2 s of the motion cover all of it.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(round(seconds * rate_hz)) / rate_hz
    centre = np.array([0.0, 0.0, 0.1, 0.0])
    amp = np.array([[0.8, 0.9, 0.05, 2.0], [0.4, 0.5, 0.03, 1.0]]) * rng.uniform(0.7, 1.0, 4)
    omega = np.pi * np.array([[1.0, 2.0, 1.0, 3.0], [3.0, 1.0, 2.0, 2.0]])  # rad/s
    phase = rng.uniform(0.0, 2 * np.pi, (2, 4))
    arg = omega[:, None, :] * t[None, :, None] + phase[:, None, :]
    q = centre + (amp[:, None, :] * np.sin(arg)).sum(axis=0)
    qd = (amp[:, None, :] * omega[:, None, :] * np.cos(arg)).sum(axis=0)
    qdd = -(amp[:, None, :] * omega[:, None, :] ** 2 * np.sin(arg)).sum(axis=0)
    model = PhysicalModel.from_urdf_file(URDF)
    model.set_theta(model.urdf_parameters())
    effort = (model.predict(np.hstack([q, qd, qdd])) + VISCOUS * qd
              + COULOMB * np.tanh(qd / EPS))
    stamps = 1_700_000_000_000_000_000 + np.round(t * 1e9).astype(np.int64)
    return States(stamps, NAMES, q, qd, effort)


def table(text: str, first: str) -> dict[str, list[str]]:
    """Rows of the first Markdown table whose header starts with ``| first``."""
    rows: dict[str, list[str]] = {}
    inside = False
    for line in text.splitlines():
        if not inside and line.startswith(f'| {first}'):
            inside = True
        elif inside and line.startswith('| ') and not line.startswith('|---'):
            cells = [c.strip() for c in line.strip('|').split('|')]
            rows[cells[0]] = cells[1:]
        elif inside and not line.startswith('|'):
            break
    return rows


@pytest.fixture(scope='module')
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp('scara_bags')
    return {'train': write_rosbag(root / 'train', scara_states(6.0, seed=1), storage='mcap'),
            'other': write_rosbag(root / 'other', scara_states(2.0, seed=2), storage='mcap')}


def test_physical_train_then_evaluate(bags: dict[str, Path], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'physical.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--method', 'physical',
                             '--urdf', URDF, '--out', model_path)
    assert code == 0, err
    assert 'PHYSICAL fitted by least squares on ' in out
    # the Coulomb shape of the data (tanh(qd/0.05)) kept on the later motion, no offsets
    # nor coupling added (the data have none)
    assert ('physical model options: tanh 0.05 (mean NMSE on the later motion: tanh 0.05 '
            in out)
    # every training sample (--samples is for networks): 4.2 s before the later motion's
    # 1.8 s, 4 of its 5 blocks of 1 s; then refitted on all 3000
    assert 'training on 2000, validating on 100' in out
    assert 'least squares on 2000 samples' in out
    assert 'then refitted on all 3000 samples (its physical part' in out
    assert list(table(out, 'joint | viscous')) == list(NAMES)
    model = PhysicalModel.load(model_path)
    assert model.joint_names == NAMES and str(model.metadata['method']) == 'physical'
    assert (model.coulomb, model.coulomb_eps) == ('tanh', EPS)
    # the q'' estimate is the only error: friction within 2 %, validation NMSE tiny
    np.testing.assert_allclose(model.viscous, VISCOUS, rtol=0.02, atol=0.01)
    np.testing.assert_allclose(model.coulomb_friction, COULOMB, rtol=0.02, atol=0.01)
    parameters = table(out, 'base parameter')
    assert set(parameters) == set(model.parameter_names[:model.n_base])
    # each with its %σ, as the model file holds it, and the condition number
    assert model.uncertainty is not None
    relative = dict(zip(model.parameter_names, model.uncertainty.relative_std))
    assert float(parameters['quill.m'][2]) == pytest.approx(100 * relative['quill.m'],
                                                            rel=0.05)
    assert f'Condition number of the regressor: {model.uncertainty.condition_number:.4g}' in out

    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err
    assert 'PHYSICAL model' in out and 'mapped by name' in out
    errors = table(out, 'joint | other MSE')
    assert float(errors['mean'][1]) < 1e-4  # NMSE on another motion
    # the parameters again, with the URDF's values beside the identified ones
    parameters = table(out, 'base parameter')
    assert 'quill.m' in parameters
    identified, from_urdf = (float(v) for v in parameters['quill.m'][:2])
    assert identified == pytest.approx(from_urdf, rel=0.02)  # quill + wrist: 4.5 kg
    assert from_urdf == pytest.approx(4.5)


def test_hybrid_train_then_evaluate(bags: dict[str, Path], tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'hybrid.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--method', 'hybrid',
                             '--urdf', URDF, '--iterations', '8', '--samples', '600',
                             '--min-iterations', '0', '--out', model_path)
    assert code == 0, err
    assert 'HYBRID: least squares on 2000 samples, then FFS on its residual: ' in out
    assert '/8 mse ' in err  # the network's progress bar
    model = HybridModel.load(model_path)
    assert model.joint_names == NAMES and str(model.metadata['network']) == 'ffs'
    assert model.network.activation == 'sigmoid'
    # inputs scaled by the URDF's position and velocity limits
    np.testing.assert_allclose(model.network.x_scaling.hi[:8],
                               [2.3, 2.5, 0.2, 6.28, 7.0, 12.0, 1.1, 26.0])
    # outputs by the residual's range, far inside the effort limits
    assert np.all(model.network.y_scaling.hi < 0.5 * np.array([250.0, 100.0, 250.0, 10.0]))
    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err
    assert 'HYBRID model' in out
    assert float(table(out, 'joint | other MSE')['mean'][1]) < 1e-3
    assert 'quill.m' in table(out, 'base parameter')


def test_urdf_gives_a_network_its_limit_scaling(bags: dict[str, Path], tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'ffs.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--method', 'ffs', '--urdf', URDF,
                             '--iterations', '2', '--out', model_path)
    assert code == 0, err
    network = FeedForwardNet.load(model_path)
    np.testing.assert_allclose(network.y_scaling.hi, [250.0, 100.0, 250.0, 10.0])
    np.testing.assert_allclose(network.x_scaling.lo[:4], [-2.3, -2.5, 0.0, -6.28])
    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err
    assert 'FFS model' in out and 'base parameter' not in out


def test_physical_needs_a_urdf_of_the_joints(bags: dict[str, Path], tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_cli(capsys, 'train', bags['train'], '--method', 'physical', '--out',
                           tmp_path / 'm.npz')
    assert code == 2 and err.count('\n') == 1 and 'needs the robot\'s --urdf' in err
    other = tmp_path / 'other.urdf'
    other.write_text(URDF.read_text().replace('joint4', 'wrist_joint'))
    code, _, err = run_cli(capsys, 'train', bags['train'], '--method', 'physical', '--urdf',
                           other, '--out', tmp_path / 'm.npz')
    assert code == 2 and err.count('\n') == 1 and 'not distinct joints of the URDF' in err
    assert not (tmp_path / 'm.npz').exists()


def test_a_continuous_joint_scales_by_the_data(bags: dict[str, Path], tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """No limits in the URDF for a continuous wrist: its ranges come from the recording."""
    urdf = tmp_path / 'continuous.urdf'
    urdf.write_text(URDF.read_text().replace('<joint name="joint4" type="revolute">',
                                             '<joint name="joint4" type="continuous">'))
    code, out, err = run_cli(capsys, 'train', bags['train'], '--method', 'hybrid', '--urdf',
                             urdf, '--iterations', '2', '--samples', '300', '--out',
                             tmp_path / 'h.npz')
    assert code == 0, err
    network = HybridModel.load(tmp_path / 'h.npz').network
    np.testing.assert_allclose(network.x_scaling.hi[:3], [2.3, 2.5, 0.2])  # the URDF's
    assert network.x_scaling.hi[3] < 6.0  # the wrist's largest angle in the recording
