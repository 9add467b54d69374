"""``scara-ident export``: a saved model as ONNX, and every refusal as one line, exit 2."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import onnxruntime
import pytest

from scara_ident_ros.cli import main
from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn import onnx_export
from robot_scaling import robot_scaling  # test/robot_scaling.py
from in_process_cli import run_cli  # test/in_process_cli.py

PARAMS = ScaraParams()
JOINTS = ['shoulder', 'elbow', 'quill', 'wrist']


def saved_model(path: Path, method: str = 'ffw', *, names: bool = True) -> FeedForwardNet:
    """A SCARA network of ``method`` with limit scaling, saved at ``path`` as train does."""
    network = make_network(method, 4, seed=1, friction_steps=True)
    network.set_scaling(*robot_scaling(PARAMS))
    network.metadata['method'] = np.array(method)
    if names:
        network.metadata['joint_names'] = np.array(JOINTS)
    network.save(path)
    return network


def effort(path: Path, X: np.ndarray) -> np.ndarray:
    session = onnxruntime.InferenceSession(str(path), providers=['CPUExecutionProvider'])
    return np.asarray(session.run(['effort'], {'x': X})[0])


def test_export_writes_a_model_onnx_runtime_runs(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    network = saved_model(tmp_path / 'ffw.npz')
    out = tmp_path / 'controllers' / 'ffw.onnx'  # a folder that does not exist yet
    code, stdout, err = run_cli(capsys, 'export', tmp_path / 'ffw.npz', '--out', out)
    assert code == 0, err
    assert f'{out}: FFW 12-40-4' in stdout and 'joints: shoulder, elbow, quill, wrist' in stdout
    assert 'checked with ONNX Runtime on 1000 random inputs' in stdout
    X = np.random.default_rng(9).uniform(network.x_scaling.lo, network.x_scaling.hi, (200, 12))
    expected = network.predict(X)
    assert np.all(np.abs(effort(out, X) - expected).max(0) < 1e-6 * np.abs(expected).max(0))
    props = {p.key: p.value for p in onnx.load(str(out)).metadata_props}
    assert props['joint_names'] == ','.join(JOINTS) and props['method'] == 'ffw'


def test_default_out_is_the_model_with_suffix_onnx(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    saved_model(tmp_path / 'model.npz', 'ffmw', names=False)
    code, stdout, err = run_cli(capsys, 'export', tmp_path / 'model.npz')
    assert code == 0, err
    assert 'joints: not recorded in the model' in stdout
    props = {p.key: p.value for p in onnx.load(str(tmp_path / 'model.onnx')).metadata_props}
    assert props['method'] == 'ffmw' and 'joint_names' not in props


def test_bad_models_and_outputs_give_one_line(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / 'ffs.npz'
    saved_model(model, 'ffs')
    (tmp_path / 'garbage.npz').write_bytes(b'not a model')
    FeedForwardNet(12, 5, 3).save(tmp_path / 'other.npz')  # not 3n inputs for n outputs
    (tmp_path / 'folder.onnx').mkdir()
    (tmp_path / 'file').write_text('')
    cases = {
        (tmp_path / 'missing.npz',): 'no such model file',
        (tmp_path,): 'is a directory',
        (tmp_path / 'garbage.npz',): 'not a .npz network file',
        (tmp_path / 'other.npz',): 'not an inverse-dynamics model',
        (model, '--out', tmp_path / 'folder.onnx'): 'is a directory; give a file name',
        (model, '--out', tmp_path / 'file' / 'x.onnx'): 'its folder exists and is not a',
        (model, '--out', model): 'is the model file itself',
    }
    before = sorted(p.name for p in tmp_path.rglob('*'))
    for argv, message in cases.items():
        code, stdout, err = run_cli(capsys, 'export', *argv)
        assert code == 2, argv
        assert err.startswith('scara-ident export: error: ') and message in err, err
        assert len(err.strip().splitlines()) == 1 and stdout == ''
    assert sorted(p.name for p in tmp_path.rglob('*')) == before  # nothing written


def test_an_export_that_disagrees_with_predict_is_not_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """If ONNX Runtime computed something else (here: another network's export), the command
    refuses before writing, so that a controller never loads a wrong model."""
    saved_model(tmp_path / 'ffs.npz', 'ffs')
    other = make_network('ffs', 4, seed=99)
    original = onnx_export.network_to_onnx
    monkeypatch.setattr(onnx_export, 'network_to_onnx',
                        lambda network, **kwargs: original(other, **kwargs))
    code, _, err = run_cli(capsys, 'export', tmp_path / 'ffs.npz')
    assert code == 2 and 'ONNX Runtime differs from predict by' in err
    assert 'not written' in err and not (tmp_path / 'ffs.onnx').exists()


def test_help_explains(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(['export', '--help'])
    text = capsys.readouterr().out
    assert '--out' in text and 'ONNX Runtime' in text and 'ros2_control' in text
