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


def test_urdf_export_of_a_physical_model_reproduces_its_rigid_body_efforts(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--urdf``: Pinocchio loads the written URDF and its rnea is the model's rigid-body
    effort (consistent standard parameters) on random states; friction in <dynamics>."""
    import pinocchio as pin
    import xml.etree.ElementTree as ET

    from scara_ident_ros.dynamics.consistent_parameters import consistency_report
    from scara_ident_ros.learners.hybrid_model import HybridModel
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.dynamics.urdf_export import rigid_body_effort
    from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot
    from physical_robots import SCARA_URDF, example_urdf, rnea, states

    panda = example_urdf('panda_description/urdf/panda.urdf')
    arm = tuple(f'panda_joint{i}' for i in range(1, 8))  # the fingers locked
    for urdf, joints in ((SCARA_URDF, None), (panda, arm)):
        model = PhysicalModel.from_urdf_file(urdf, joint_names=joints, consistent=True)
        n = model.n_joints
        rng = np.random.default_rng(5)
        q, qd, qdd = states(rng, 200, n)
        tau = rnea(urdf, joints, q, qd, qdd) * 1.1 + 0.4 * qd + 0.9 * np.tanh(qd / 0.05)
        model.fit_states(q, qd, qdd, tau)
        # noise-free efforts: the %σ of parameters near 0 means nothing (priors: below)
        model.uncertainty = None
        model.save(tmp_path / 'physical.npz')
        out = tmp_path / f'{urdf.stem}_identified.urdf'
        code, stdout, err = run_cli(capsys, 'export', tmp_path / 'physical.npz', '--urdf', out)
        assert code == 0, err
        assert 'checked with Pinocchio' in stdout
        q, qd, qdd = states(rng, 30, n)
        np.testing.assert_allclose(rnea(out, joints, q, qd, qdd),
                                   rigid_body_effort(model, model.standard_theta, q, qd, qdd),
                                   atol=1e-9, rtol=1e-9)
        loaded = pin.buildModelFromUrdf(str(out))
        for body in model.body_names:  # every written link a real body
            inertia = loaded.inertias[loaded.frames[loaded.getFrameId(body)].parentJoint]
            assert consistency_report(inertia.toDynamicParameters())['mass'] > 0.0
        # robot_sim (-p urdf_file:=) builds its simulated arm from it
        robot = PinocchioRobot.from_urdf(out, joints=joints or ())
        assert robot.n_joints == n
        root = ET.parse(out).getroot()
        for name, viscous in zip(model.joint_names, model.viscous):
            dynamics = root.find(f"joint[@name='{name}']/dynamics")
            assert dynamics is not None
            assert float(dynamics.get('damping', 'nan')) == pytest.approx(viscous, rel=1e-12)
    # a hybrid's physical part is written too; a network is refused in one line
    hybrid = HybridModel(model, make_network('ffs', n, n_hidden=4))
    hybrid.save(tmp_path / 'hybrid.npz')
    code, _, err = run_cli(capsys, 'export', tmp_path / 'hybrid.npz', '--urdf',
                           tmp_path / 'hybrid.urdf')
    assert code == 0 and (tmp_path / 'hybrid.urdf').exists(), err
    saved_model(tmp_path / 'ffs.npz', 'ffs')
    code, _, err = run_cli(capsys, 'export', tmp_path / 'ffs.npz', '--urdf', tmp_path / 'x')
    assert code == 2 and 'without a physical model of a URDF' in err
    assert not (tmp_path / 'x').exists()


def test_urdf_export_keeps_the_urdfs_values_where_the_data_do_not_determine_them(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The wrist (joint4) held still: its friction and rotor inertia keep their priors (the
    URDF's: no friction), the other joints' identified friction is written."""
    import xml.etree.ElementTree as ET

    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from physical_robots import SCARA_URDF, rnea, states

    model = PhysicalModel.from_urdf_file(SCARA_URDF)
    q, qd, qdd = states(np.random.default_rng(3), 300, 4)
    q[:, 3], qd[:, 3], qdd[:, 3] = 0.5, 0.0, 0.0
    tau = rnea(SCARA_URDF, None, q, qd, qdd) + 0.4 * qd + 0.9 * np.tanh(qd / 0.05)
    tau += np.random.default_rng(4).normal(0.0, 0.05, tau.shape)
    model.fit_states(q, qd, qdd, tau)
    assert model.uncertainty is not None
    assert {'joint4.fv', 'joint4.fc'} <= set(model.uncertainty.undetermined_names)
    model.save(tmp_path / 'physical.npz')
    out = tmp_path / 'identified.urdf'
    code, stdout, err = run_cli(capsys, 'export', tmp_path / 'physical.npz', '--urdf', out)
    assert code == 0, err
    kept = stdout.split("kept at the URDF's values: ")[1].split(', ')
    assert 'joint4.fv' in kept and 'joint1.fv' not in kept
    joints = {joint.get('name'): joint.find('dynamics')
              for joint in ET.parse(out).getroot().iter('joint')}
    assert float(joints['joint4'].get('damping')) == 0.0
    assert float(joints['joint4'].get('friction')) == 0.0
    assert float(joints['joint1'].get('damping')) == pytest.approx(0.4, rel=0.05)
