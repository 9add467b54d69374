"""The sparse-spectrum GP: online learning equals the batch solution, it predicts what it
learnt, its variance means something, and its file round-trips through load_model."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.estimator import OnlineEstimator, load_model
from scara_ident_ros.learners import SparseSpectrumGP
from scara_ident_ros.learners.ard_hyperparameters import fit_ard_hyperparameters
from scara_ident_ros.nn import ModelFormatError


def data(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Two 'joints' of smooth functions of 6 inputs, a little noise."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, 6))
    y = np.c_[3.0 * np.sin(2.0 * x[:, 0]) + x[:, 3] ** 2, 0.5 * np.cos(x[:, 1] * x[:, 2])]
    return x, y + 0.01 * rng.standard_normal(y.shape)


@pytest.mark.parametrize('per_joint', [False, True])
@pytest.mark.parametrize('batch', [1, 7])
def test_online_equals_batch(per_joint: bool, batch: int) -> None:
    x, y = data()
    offline = SparseSpectrumGP(60, hyperparameters='scale', per_joint=per_joint).fit(x, y)
    online = SparseSpectrumGP(60, hyperparameters='scale', per_joint=per_joint, refresh=90)
    online.set_kernel(x, y)  # the same standardisation and kernel as fit's
    for start in range(0, len(x), batch):
        online.partial_fit(x[start:start + batch], y[start:start + batch])
    assert online.n_samples_ == offline.n_samples_ == len(x)
    np.testing.assert_allclose(online.predict(x), offline.predict(x), rtol=0, atol=1e-9)
    # 400 samples, refresh 90: the last 40 were learnt by the recursive update alone
    np.testing.assert_allclose(online._weights, offline._weights, rtol=0, atol=1e-8)


def test_partial_fit_predicts_before_learning() -> None:
    x, y = data()
    model = SparseSpectrumGP(60, hyperparameters='scale')
    first = model.partial_fit(x[:200], y[:200])
    np.testing.assert_array_equal(first[0], model.y_mean_)  # nothing learnt: the mean
    before = model.predict(x[200:210])
    np.testing.assert_allclose(model.partial_fit(x[200:210], y[200:210])[0], before[0])
    assert isinstance(model, OnlineEstimator)


def test_learns_and_variance_tracks_error() -> None:
    x, y = data(600)
    model = SparseSpectrumGP(200, per_joint=True, hyper_samples=300).fit(x[:500], y[:500])
    assert model.score(x[500:], y[500:]) > 0.95
    prediction, std = model.predict_std(x[500:])
    rms = np.sqrt(((prediction - y[500:]) ** 2).mean(axis=0))
    assert np.all(std.mean(axis=0) > 0.3 * rms) and np.all(std.mean(axis=0) < 3.0 * rms)
    _, far = model.predict_std(x[500:] + 5.0)  # far from every sample
    assert np.all(far.mean(axis=0) > 10.0 * std.mean(axis=0))


def test_ard_finds_the_irrelevant_inputs() -> None:
    x, y = data(300)
    hyper = fit_ard_hyperparameters((x - x.mean(0)) / x.std(0), (y - y.mean(0)) / y.std(0),
                                    per_joint=True, samples=300)
    assert hyper.length_scales.shape == (2, 6)
    assert hyper.length_scales[0, 4] > 10 * hyper.length_scales[0, 0]  # joint 0: x4 unused
    assert hyper.length_scales[1, 0] > 10 * hyper.length_scales[1, 1]  # joint 1: x0 unused


def test_file_round_trip(tmp_path: Path) -> None:
    x, y = data()
    model = SparseSpectrumGP(40, hyperparameters='scale', per_joint=True).fit(x[:300], y[:300])
    model.partial_fit(x[300:310], y[300:310])  # unfolded rows are saved too
    model.metadata['joint_names'] = np.array(['a', 'b'])
    path = tmp_path / 'kernel.npz'
    model.save(path)
    loaded = load_model(path)
    assert isinstance(loaded, SparseSpectrumGP)
    assert loaded.get_params() == model.get_params() and loaded.joint_names == ('a', 'b')
    np.testing.assert_allclose(loaded.predict(x[310:]), model.predict(x[310:]), atol=1e-9)
    np.testing.assert_allclose(loaded.partial_fit(x[310:], y[310:]),
                               model.partial_fit(x[310:], y[310:]), atol=1e-9)


def test_weights_in_the_file_spare_the_solve_and_files_without_them_still_load(
        tmp_path: Path) -> None:
    from scara_ident_ros.nn.model_file import write_model

    x, y = data()
    model = SparseSpectrumGP(40, hyperparameters='scale').fit(x[:300], y[:300])
    arrays = model.to_arrays()
    quick = SparseSpectrumGP.from_arrays(arrays, source='arrays')
    assert quick._inverse_due  # predicts with the saved W; A⁻¹ only when it learns again
    np.testing.assert_allclose(quick.predict(x[300:]), model.predict(x[300:]), atol=1e-12)
    older = {key: value for key, value in arrays.items() if key != 'weights'}
    write_model(tmp_path / 'old.npz', older, {}, kind='kernel')
    loaded = load_model(tmp_path / 'old.npz')
    np.testing.assert_allclose(loaded.predict(x[300:]), model.predict(x[300:]), atol=1e-9)
    np.testing.assert_allclose(quick.partial_fit(x[300:], y[300:]),
                               loaded.partial_fit(x[300:], y[300:]), atol=1e-9)
    write_model(tmp_path / 'bad.npz', {**arrays, 'weights': arrays['weights'][:, :3]}, {},
                kind='kernel')
    with pytest.raises(ModelFormatError, match='weights must be'):
        load_model(tmp_path / 'bad.npz')


def test_corrupt_file_is_refused(tmp_path: Path) -> None:
    x, y = data(50)
    model = SparseSpectrumGP(20, hyperparameters='scale').fit(x, y)
    arrays = model.to_arrays()
    arrays['omega'] = arrays['omega'][:, :5]
    from scara_ident_ros.nn.model_file import write_model
    write_model(tmp_path / 'bad.npz', arrays, {}, kind='kernel')
    with pytest.raises(ModelFormatError, match='corrupt kernel model'):
        load_model(tmp_path / 'bad.npz')


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match='even'):
        SparseSpectrumGP(31)
    with pytest.raises(RuntimeError, match='learnt nothing'):
        SparseSpectrumGP(20).predict(np.zeros((1, 3)))
    model = SparseSpectrumGP(20, hyperparameters='scale').fit(*data(50))
    with pytest.raises(ValueError, match='maps 6 inputs'):
        model.partial_fit(np.zeros((1, 3)), np.zeros((1, 2)))
