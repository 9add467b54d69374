"""The estimator contract: every model fits, scores, saves and loads with the same calls."""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros import (Estimator, ExactGP, FeedForwardNet, HybridModel,
                             LinearFeatures, OnlineEstimator, PhysicalModel, SparseSpectrumGP,
                             load_model, make_network, r2_score)
from scara_ident_ros.estimator import registered_kinds
from scara_ident_ros.nn import ModelFormatError
from scara_ident_ros.nn.validation_blocks import row_split

WAM = Path(__file__).resolve().parents[2] / 'shared' / 'realdata' / 'barrett_wam.npz'
if not WAM.exists():  # a worktree under /work/wt/<name>
    WAM = Path('/work/shared/realdata/barrett_wam.npz')
ROWS = 800  # training rows of the WAM (of 12,000): seconds, not minutes


def wam() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    if not WAM.exists():
        pytest.skip(f'{WAM}: the real-data folder is not on this machine')
    with np.load(WAM) as data:
        return (data['X_train'][:ROWS], data['Y_train'][:ROWS], data['X_test'][:500],
                data['Y_test'][:500])


def example_urdf(suffix: str) -> Path:
    """A URDF of the installed example-robot-data, found through its file record."""
    for file in importlib.metadata.files('example-robot-data') or ():
        if str(file).endswith(suffix):
            return Path(str(file.locate()))
    raise FileNotFoundError(suffix)


def test_every_model_kind_is_registered() -> None:
    assert {'network', 'physical', 'hybrid', 'kernel', 'gp', 'linear'} <= set(
        registered_kinds())


def test_r2_score_is_one_minus_the_mean_nmse() -> None:
    y = np.array([[0.0, 1.0], [2.0, 1.0], [4.0, 1.0]])  # joint 2 constant: left out
    p = y + np.array([[1.0, 5.0], [-1.0, 5.0], [0.0, 5.0]])
    assert r2_score(y, p) == pytest.approx(1.0 - (2.0 / 3.0) / (8.0 / 3.0))
    assert r2_score(y, y) == 1.0


@pytest.mark.parametrize('make', [
    lambda: FeedForwardNet(21, 10, 7, 'sigmoid'),
    lambda: make_network('ffs', 7, n_hidden=10, friction_steps=True),
    lambda: make_network('ffmw', 7, n_hidden=10, seed=3),
], ids=['net', 'ffs-friction-steps', 'ffmw'])
def test_three_lines_fit_score_and_save_the_wam(tmp_path: Path, make) -> None:
    X, Y, Xt, Yt = wam()
    path = tmp_path / 'wam.npz'
    model = make()
    model.fit(X, Y, iterations=8)
    r2 = model.score(Xt, Yt)
    model.save(path)

    assert isinstance(model, Estimator)
    assert model.history_ is not None and 1 <= model.history_.iterations <= 8
    assert model.scaling_set
    # better than predicting each joint's mean, not perfect on held-out motion
    assert 0.0 < r2 < 1.0
    assert r2 == pytest.approx(1.0 - np.mean(((Yt - model.predict(Xt)) ** 2).mean(axis=0)
                                             / Yt.var(axis=0)))
    same = load_model(path)
    assert type(same) is FeedForwardNet and same.kind == 'network'
    np.testing.assert_array_equal(same.predict(Xt), model.predict(Xt))
    assert same.score(Xt, Yt) == r2
    assert same.get_params() == model.get_params()
    again = FeedForwardNet(**model.get_params())  # hyperparameters as constructor data
    assert again.get_params() == model.get_params()


@pytest.mark.parametrize('make', [
    lambda: SparseSpectrumGP(400, hyperparameters='scale'),
    lambda: ExactGP(),
    LinearFeatures,
], ids=['sparse-spectrum-gp', 'exact-gp', 'linear'])
def test_three_lines_fit_score_and_save_the_wam_with_a_learner(tmp_path: Path, make) -> None:
    X, Y, Xt, Yt = wam()
    path = tmp_path / 'wam.npz'
    model = make()
    model.fit(X, Y)
    r2 = model.score(Xt, Yt)
    model.save(path)

    assert isinstance(model, OnlineEstimator if model.kind != 'linear' else Estimator)
    assert 0.0 < r2 < 1.0  # better than each joint's mean on held-out rows
    same = load_model(path)
    assert type(same) is type(model) and same.kind == model.kind
    np.testing.assert_allclose(same.predict(Xt), model.predict(Xt), rtol=1e-12, atol=1e-12)
    assert type(model)(**model.get_params()).get_params() == model.get_params()


def test_network_fit_holds_out_spread_row_blocks() -> None:
    train, validation = row_split(1000, 0.2, seed=0)
    assert train.shape[0] + validation.shape[0] == 1000
    assert np.intersect1d(train, validation).size == 0
    assert validation.shape[0] == 200  # 10 of 50 blocks of 20 rows
    assert validation.min() < 200 and validation.max() >= 800  # spread over the rows
    train, validation = row_split(1000, 0.0)
    assert train.shape[0] == 1000 and validation.shape[0] == 0


def test_fit_without_validation_runs_every_iteration() -> None:
    X, Y, _, _ = wam()
    net = FeedForwardNet(21, 5, 7, 'sigmoid').fit(X[:200], Y[:200], iterations=4,
                                                  validation_fraction=0.0)
    assert net.history_ is not None and net.history_.iterations == 4
    assert net.history_.val_mse is None and net.history_.stop_reason == 'iterations'


def test_load_model_refuses_what_is_no_model(tmp_path: Path) -> None:
    (tmp_path / 'x.npz').write_bytes(b'not a zip')
    with pytest.raises(ModelFormatError, match='not a .npz'):
        load_model(tmp_path / 'x.npz')


def test_physical_and_hybrid_keep_the_contract_on_a_urdf_arm(tmp_path: Path) -> None:
    urdf = example_urdf('ur_description/urdf/ur5_robot.urdf')
    physical = PhysicalModel.from_urdf_file(urdf)
    n = physical.n_joints
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1.0, 1.0, (250, n)), rng.normal(0.0, 1.5, (250, n)),
                  rng.normal(0.0, 5.0, (250, n)))
    truth = physical.urdf_parameters() + rng.uniform(0.0, 0.5, physical.n_parameters)
    X = np.hstack([q, qd, qdd])
    Y = physical.regressor(q, qd, qdd) @ truth + 0.05 * np.sin(3.0 * q)
    Xt, Yt = X[200:], Y[200:]

    for model in (PhysicalModel.from_urdf_file(urdf, coulomb='sign'),
                  HybridModel(PhysicalModel.from_urdf_file(urdf),
                              make_network('ffs', n, n_hidden=8))):
        path = tmp_path / f'{model.kind}.npz'
        assert isinstance(model, Estimator)
        if isinstance(model, HybridModel):
            model.fit(X[:200], Y[:200], iterations=10, min_iterations=0)
            assert model.history_ is not None
            assert set(model.get_params()) == {'physical', 'network'}
        else:
            model.fit(X[:200], Y[:200])
            assert model.get_params()['coulomb'] == 'sign'
        r2 = model.score(Xt, Yt)
        model.save(path)
        assert 0.9 < r2 <= 1.0
        same = load_model(path)
        assert type(same) is type(model) and same.kind == model.kind
        assert same.joint_names == model.joint_names and same.method == model.kind
        np.testing.assert_array_equal(same.predict(Xt), model.predict(Xt))
