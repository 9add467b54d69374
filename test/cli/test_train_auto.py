"""``scara-ident train`` without ``--method`` (auto): the best learner on validation blocks,
the hybrid with a URDF; and ``--method linear``."""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.cli.train import AUTO_CANDIDATES
from scara_ident_ros.learners.hybrid_model import HybridModel
from scara_ident_ros.estimator import load_model
from scara_ident_ros.learners import LinearFeatures

sys.path.insert(0, str(Path(__file__).resolve().parent))
from in_process_cli import run_cli  # noqa: E402  (test/in_process_cli.py)
from test_train_physical import URDF, bags, table  # noqa: E402, F401  (bags: a fixture)

pytestmark = pytest.mark.slow  # a GP and a network are fitted to choose


def test_auto_saves_the_candidate_of_the_lowest_validation_error(
        bags: dict[str, Path], tmp_path: Path,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'auto.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--out', model_path)
    assert code == 0, err
    scores = {m: float(v) for m, v in re.findall(r'^auto: (\w+) mean NMSE (\S+) on ', out,
                                                   flags=re.MULTILINE)}
    assert set(scores) == set(AUTO_CANDIDATES)
    chosen = min(scores, key=scores.__getitem__)
    assert f'auto: {chosen.upper()}, the lowest mean validation NMSE of ' in out
    model = load_model(model_path)
    assert model.method == chosen and str(model.metadata['chosen_by']) == 'auto'
    assert float(model.metadata[f'auto_nmse_{chosen}']) == pytest.approx(scores[chosen],
                                                                          rel=1e-3)
    # on this smooth motion a learner beats the linear baseline, and the choice is kept
    assert chosen != 'linear' and scores[chosen] < scores['linear']
    assert float(table(out, 'joint')['mean'][3]) < 1e-2  # validation NMSE of the saved
    code, out, err = run_cli(capsys, 'evaluate', model_path, bags['other'])
    assert code == 0, err


def test_auto_with_a_urdf_is_the_hybrid(bags: dict[str, Path], tmp_path: Path,  # noqa: F811
                                        capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'hybrid.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--urdf', URDF,
                             '--iterations', '5', '--out', model_path)
    assert code == 0, err
    assert '--method auto with --urdf: hybrid' in out
    assert isinstance(load_model(model_path), HybridModel)


def test_auto_without_validation_blocks_is_refused(
        bags: dict[str, Path], tmp_path: Path,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_cli(capsys, 'train', bags['train'], '--validation-fraction', '0',
                           '--out', tmp_path / 'none.npz')
    assert code != 0
    assert 'chooses on validation samples and has 0' in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / 'none.npz').exists()


def test_linear_train_then_evaluate(bags: dict[str, Path], tmp_path: Path,  # noqa: F811
                                    capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / 'linear.npz'
    code, out, err = run_cli(capsys, 'train', bags['train'], '--method', 'linear',
                             '--out', model_path)
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
    assert load_model(model_path).method in ('linear', 'ffs')


def test_linear_hybrid_is_no_worse_than_linear_on_its_validation_blocks(
        bags: dict[str, Path], tmp_path: Path,  # noqa: F811
        capsys: pytest.CaptureFixture[str]) -> None:
    """``--method linear_hybrid``: linear least squares plus a gated FFS network of its
    residual; gated on the validation blocks, it cannot be worse than linear there."""
    errors = {}
    for method in ('linear', 'linear_hybrid'):
        code, out, err = run_cli(capsys, 'train', bags['train'], '--method', method,
                                 '--iterations', '20', '--validation-block', '0.25',
                                 '--out', tmp_path / f'{method}.npz')  # 5 blocks to gate on
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
