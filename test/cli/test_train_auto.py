"""``scara-ident train`` without ``--method`` (auto): per joint the best candidate on later
motion, the physical model unless another is clearly better with a URDF; and ``--method
linear``."""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.cli.train import AUTO_CANDIDATES, URDF_CANDIDATES
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.learners.hybrid_model import HybridModel
from scara_ident_ros.estimator import load_model
from scara_ident_ros.learners import LinearFeatures
from scara_ident_ros.learners.joint_choice import MARGIN

sys.path.insert(0, str(Path(__file__).resolve().parent))
from in_process_cli import run_cli  # noqa: E402  (test/in_process_cli.py)
from test_train_physical import (URDF, States, bags, scara_states, table,  # noqa: E402, F401
                                 write_rosbag)  # (bags: a fixture)

pytestmark = pytest.mark.slow  # a GP and a network are fitted to choose


def _scores(out: str) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray],
                             dict[str, np.ndarray]]:
    """Each candidate's NMSE per joint on the later motion, on the validation blocks and on
    the two halves of the later motion in time (2, n), as ``auto`` prints them."""
    later, blocks, halves = {}, {}, {}
    for method, values, rest in re.findall(r'^auto: (\w+) NMSE per joint ([^(]+) \(mean '
                                           r'[^)]+\) on \d+ held-out samples(.*)$', out,
                                           flags=re.MULTILINE):
        later[method] = np.array([float(v) for v in values.split(',')])
        found = re.match(r' \(validation blocks: ([^)]+)\)', rest)
        if found:
            blocks[method] = np.array([float(v) for v in found.group(1).split(',')])
        found = re.search(r'\(halves in time: ([^)]+)\)', rest)
        assert found, rest
        halves[method] = np.array([[float(v) for v in half.split(',')]
                                   for half in found.group(1).split(';')])
    return later, blocks, halves


def test_auto_keeps_per_joint_the_candidate_of_the_lowest_error_on_later_motion(
        bags: dict[str, Path], tmp_path: Path,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'auto.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--iterations', '30',
                             '--out', model_path)
    assert code == 0, err
    assert 'later motion, held out to choose and stop on: ' in out
    later, blocks, halves = _scores(out)
    assert set(later) == set(AUTO_CANDIDATES) and set(blocks) == set(AUTO_CANDIDATES)
    model = load_model(model_path)
    chosen = [str(v) for v in model.metadata['joint_choice']]
    for j, method in enumerate(chosen):
        # linear unless another is clearly better on both halves (printed to 3 digits)
        beaten = [m for m in halves
                  if np.all(halves[m][:, j] <= MARGIN * halves['linear'][:, j] * 1.01)]
        if method == 'linear':
            assert not [m for m in beaten if m != 'linear' and np.all(
                halves[m][:, j] <= MARGIN * halves['linear'][:, j] * 0.99)], (j, halves)
        else:
            assert method in beaten, (j, method, halves)
            assert later[method][j] <= min(later[m][j] for m in beaten) * 1.01, (j, later)
    assert str(model.metadata['chosen_by']) == 'auto'
    assert model.method == (chosen[0] if len(set(chosen)) == 1 else 'joint_choice')
    # on this smooth motion a learner beats the linear baseline somewhere
    assert set(chosen) != {'linear'}
    assert '| later MSE | later NMSE |' in out  # the later motion's errors are reported
    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err


def test_auto_with_a_urdf_keeps_the_physical_model_where_a_hybrid_wins_only_on_blocks(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The first recording's joint 1 carries a sensor offset the second does not. Chosen on
    blocks interleaved with the first recording, the hybrid keeps a correction of it (it
    wins there) that makes the second recording worse; chosen on the second recording as
    later motion, auto keeps the physical model, which predicts it better."""
    first = scara_states(6.0, seed=1)
    drifted = States(first.stamp_ns, first.names, first.position, first.velocity,
                     first.effort + np.array([4.0, 0.0, 0.0, 0.0]))
    recordings = [write_rosbag(tmp_path / 'first', drifted, storage='mcap'),
                  write_rosbag(tmp_path / 'second', scara_states(4.0, seed=3),
                               storage='mcap')]
    on_blocks = tmp_path / 'blocks.npz'
    code, out, err = run_cli(capsys, 'train', recordings[0], '--method', 'hybrid',
                             '--urdf', URDF, '--iterations', '30', '--later-fraction', '0',
                             '--coupled', 'none', '--out', on_blocks)
    assert code == 0, err
    assert load_model(on_blocks).gate[0] > 0.0  # its correction of joint 1 is kept
    model_path = tmp_path / 'auto.npz'
    code, out, err = run_cli(capsys, 'train', *recordings, '--urdf', URDF,
                             '--iterations', '30', '--out', model_path)
    assert code == 0, err
    assert f'of the last recording, {recordings[1]}' in out
    later_scores, _, _ = _scores(out)
    assert set(later_scores) == set(URDF_CANDIDATES)
    model = load_model(model_path)
    assert [str(v) for v in model.metadata['joint_choice']] == ['physical'] * 4
    assert isinstance(model, PhysicalModel)
    assert not model.offsets  # the offset did not hold on the later motion either
    errors = {}
    for path in (on_blocks, model_path):
        code, out, err = run_cli(capsys, 'evaluate', path, recordings[1])
        assert code == 0, err
        errors[path] = float(next(iter(table(out, 'joint').values()))[1])  # joint 1
    assert errors[model_path] < 0.5 * errors[on_blocks]


def test_auto_without_held_out_samples_is_refused(
        bags: dict[str, Path], tmp_path: Path,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_cli(capsys, 'train', bags['train'], '--validation-fraction', '0',
                           '--later-fraction', '0', '--out', tmp_path / 'none.npz')
    assert code != 0
    assert 'chooses on held-out samples and has 0' in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / 'none.npz').exists()


def test_linear_train_then_evaluate(bags: dict[str, Path], tmp_path: Path,  # noqa: F811
                                    capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'linear.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--method', 'linear',
                             '--later-fraction', '0', '--out', model_path)
    assert code == 0, err
    assert 'LINEAR (least squares on 25 features) fitted in ' in out
    assert 'training on 2500, validating on 500' in out  # every training sample
    model = load_model(model_path)
    assert isinstance(model, LinearFeatures) and model.method == 'linear'
    # the saved coefficients are those of a fit to the same rows, not another model's
    assert np.isfinite(model.coef_).all() and model.coef_.shape == (25, 4)
    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err
    assert out.startswith(f'LINEAR model {model_path} on ')


def test_auto_goes_on_without_a_candidate_that_refuses_the_data(
        bags: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    from scara_ident_ros.learners import ExactGP

    def refuse(self: ExactGP, X: object, Y: object) -> ExactGP:
        raise ValueError('too few samples to choose a kernel')

    monkeypatch.setattr(ExactGP, 'fit', refuse)
    model_path = tmp_path / 'auto.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--iterations', '5',
                             '--out', model_path)
    assert code == 0, err
    assert 'auto: gp not fitted: too few samples to choose a kernel' in out
    model = load_model(model_path)
    assert 'gp' not in [str(v) for v in model.metadata['joint_choice']]


def test_linear_hybrid_is_no_worse_than_linear_on_its_validation_blocks(
        bags: dict[str, Path], tmp_path: Path,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    """``--method linear_hybrid``: linear least squares plus a gated FFS network of its
    residual; gated on the validation blocks, it cannot be worse than linear there."""
    errors = {}
    for method in ('linear', 'linear_hybrid'):
        code, out, err = run_cli(capsys, 'train', bags['train'], '--method', method,
                                 '--iterations', '20', '--validation-block', '0.25',
                                 '--later-fraction', '0',  # gated on the 5 blocks
                                 '--out', tmp_path / f'{method}.npz')
        assert code == 0, err
        errors[method] = np.array([float(row[3]) for name, row in table(out, 'joint').items()
                                   if name != 'mean'])
    assert 'LINEAR_HYBRID: least squares on 2375 samples, then FFS on its residual' in out
    model = load_model(tmp_path / 'linear_hybrid.npz')
    assert isinstance(model, HybridModel) and model.method == 'linear_hybrid'
    assert model.base.kind == 'linear' and model.joint_names is not None
    assert np.all(errors['linear_hybrid'] <= errors['linear'] * (1 + 1e-9) + 1e-12)
    assert np.any(errors['linear_hybrid'] < 0.5 * errors['linear'])  # smooth dynamics
    code, out, err = run_cli(capsys, 'evaluate', tmp_path / 'linear_hybrid.npz', bags['other'])
    assert code == 0, err
