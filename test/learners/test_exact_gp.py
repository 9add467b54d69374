"""The exact GP: one pass of partial_fit equals fit on the same rows, each sample is
predicted before it is learnt, the budget and the skips hold, the 'thin' budget rule keeps
the points spread over the stream with the batch factor of the points kept, validation
picks the grid's best kernel, and its file round-trips through load_model."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.estimator import OnlineEstimator, load_model
from scara_ident_ros.learners import ExactGP
from scara_ident_ros.learners.exact_gp import choose_kernel, rbf
from scara_ident_ros.nn import ModelFormatError


def data(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Two 'joints' of smooth functions of 6 inputs, a little noise."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, 6))
    y = np.c_[3.0 * np.sin(2.0 * x[:, 0]) + x[:, 3] ** 2, 0.5 * np.cos(x[:, 1] * x[:, 2])]
    return x, y + 0.01 * rng.standard_normal(y.shape)


@pytest.mark.parametrize('batch', [1, 7])
def test_online_equals_fit(batch: int) -> None:
    x, y = data(1100)  # more than two blocks of the blockwise solves
    kernel = {'length': 2.0, 'noise': 1e-2, 'budget': 1200, 'warmup': 10, 'min_variance': 0.0}
    offline = ExactGP(**kernel).set_kernel(x[:100], y[:100]).fit(x, y)
    online = ExactGP(**kernel).set_kernel(x[:100], y[:100])
    for start in range(0, len(x), batch):
        online.partial_fit(x[start:start + batch], y[start:start + batch])
    assert online.n_points_ == offline.n_points_ == len(x)
    xt, _ = data(50, seed=1)
    np.testing.assert_allclose(online.predict(xt), offline.predict(xt), rtol=0, atol=1e-8)
    n = len(x)
    np.testing.assert_allclose(np.tril(online._factor[:n, :n]),
                               np.tril(offline._factor[:n, :n]), rtol=0, atol=1e-8)


def test_warmup_then_append_equals_fit() -> None:
    x, y = data()
    online = ExactGP(length=2.0, noise=1e-2, budget=500, warmup=100, min_variance=0.0)
    before = online.partial_fit(x, y)
    np.testing.assert_allclose(before[50], y[:50].mean(axis=0))  # warm-up: the mean so far
    offline = ExactGP(length=2.0, noise=1e-2).set_kernel(x[:100], y[:100]).fit(x, y)
    np.testing.assert_allclose(online.predict(x), offline.predict(x), rtol=0, atol=1e-8)
    assert isinstance(online, OnlineEstimator)


def test_predicts_before_learning_and_keeps_the_budget() -> None:
    x, y = data()
    model = ExactGP(length=2.0, noise=1e-2, budget=150, warmup=100, min_variance=0.0,
                    budget_rule='stop')
    model.fit(x[:100], y[:100])
    expected = model.predict(x[100:101])
    np.testing.assert_allclose(model.partial_fit(x[100:101], y[100:101]), expected,
                               rtol=0, atol=1e-10)
    model.partial_fit(x[101:], y[101:])
    assert model.n_points_ == 150  # full: the rest was predicted, not learnt
    skipper = ExactGP(length=2.0, noise=1e-2, budget=400, warmup=100, skip_within=3.0,
                      min_variance=0.0)
    skipper.partial_fit(x, y)
    assert 100 < skipper.n_points_ < 400 and skipper.n_seen_ == 400
    assert skipper.score(x, y) > 0.95
    covered = ExactGP(length=2.0, noise=1e-2, budget=800, warmup=100, min_variance=0.05)
    covered.partial_fit(*data(800))
    assert 100 < covered.n_points_ < 800


def test_validation_picks_the_grid_minimum() -> None:
    x, y = data(500)
    length, noise, scores = choose_kernel(x, y, lengths=(0.05, 1.0, 50.0), noises=(1e-4,))
    assert len(scores) == 3 and scores[length, noise] == min(scores.values())
    assert length == 1.0  # 0.05 forgets between samples, 50 cannot bend
    model = ExactGP(select_samples=300, val_block=10).fit(x[:400], y[:400])
    worse = ExactGP(length=0.05, noise=1e-4).fit(x[:400], y[:400])
    assert model.score(x[400:], y[400:]) > worse.score(x[400:], y[400:]) + 0.1
    assert len(model.selection_) == 10


def test_file_round_trip(tmp_path: Path) -> None:
    x, y = data()
    model = ExactGP(length=2.0, noise=1e-2, budget=500, warmup=100, min_variance=0.0)
    model.fit(x[:300], y[:300])
    model.metadata['method'] = np.array('gp')
    path = tmp_path / 'gp.npz'
    model.save(path)
    loaded = load_model(path)
    assert isinstance(loaded, ExactGP) and loaded.method == 'gp'
    np.testing.assert_allclose(loaded.predict(x), model.predict(x), rtol=0, atol=1e-12)
    # online on after loading: the factor is rebuilt
    np.testing.assert_allclose(loaded.partial_fit(x[300:], y[300:]),
                               model.partial_fit(x[300:], y[300:]), rtol=0, atol=1e-8)
    with np.load(path) as archive:
        arrays = dict(archive)
    arrays['alpha'] = arrays['alpha'][:-1]
    np.savez(path, **arrays)
    with pytest.raises(ModelFormatError, match='alpha'):
        load_model(path)


def test_thinning_keeps_the_budget_and_the_batch_factor() -> None:
    x, y = data(2000)
    model = ExactGP(length=2.0, noise=1e-2, budget=150, warmup=50, min_variance=0.0)
    sizes = []
    for start in range(0, len(x), 37):
        model.partial_fit(x[start:start + 37], y[start:start + 37])
        sizes.append(model.n_points_)
    # never above the budget; evicted budget // 8 at a time: at least 7/8 full once full
    assert max(sizes) == 150 and min(sizes[sizes.index(150):]) >= 150 - 150 // 8
    assert model.n_evicted_ > 150 and model.stride_ >= 8
    n, kept = model.n_points_, model._positions[:model.n_points_]
    # the factor after hundreds of rank-one updates is the batch Cholesky of the kept points
    gram = rbf(model._points[:n], model._points[:n], 2.0) + 1e-2 * np.eye(n)
    np.testing.assert_allclose(np.tril(model._factor[:n, :n]), np.linalg.cholesky(gram),
                               rtol=0, atol=1e-9)
    batch = ExactGP(length=2.0, noise=1e-2).set_kernel(x[:50], y[:50]).fit(x[kept], y[kept])
    xt, _ = data(50, seed=1)
    np.testing.assert_allclose(model.predict(xt), batch.predict(xt), rtol=0, atol=1e-9)


def test_thinning_spreads_the_kept_points_over_the_stream() -> None:
    x, y = data(2000)
    for total in (400, 1000, 1333, 2000):
        model = ExactGP(length=2.0, noise=1e-2, budget=150, warmup=50, min_variance=0.0)
        model.partial_fit(x[:total], y[:total])
        kept, stride = model._positions[:model.n_points_], model.stride_
        gaps = np.diff(kept)
        # an older part at twice the stride, then a recent part at the stride: even spacing
        assert kept[0] == 0 and total - kept[-1] <= stride
        assert set(gaps) <= {stride, 2 * stride}
        assert np.all(np.diff(gaps) >= -stride)  # the wide gaps come first
        assert total / (2 * stride) <= len(kept) <= 150
        assert len(kept) >= min(total, 150 - 150 // 8)


def test_thinning_predicts_before_evicting() -> None:
    x, y = data(600)
    model = ExactGP(length=2.0, noise=1e-2, budget=100, warmup=50, min_variance=0.0)
    model.partial_fit(x[:300], y[:300])
    for i in range(300, 320):  # learnt or only predicted: either way the model before it
        expected = model.predict(x[i:i + 1])
        np.testing.assert_allclose(model.partial_fit(x[i:i + 1], y[i:i + 1]), expected,
                                   rtol=0, atol=1e-9)
    stop = ExactGP(length=2.0, noise=1e-2, budget=100, warmup=50, min_variance=0.0,
                   budget_rule='stop')
    stop.partial_fit(x, y)  # the old rule: the first 100 samples, then predictions only
    np.testing.assert_array_equal(stop._positions[:stop.n_points_], np.arange(100))
    assert stop.n_evicted_ == 0
    with pytest.raises(ValueError, match='budget_rule'):
        ExactGP(budget_rule='reservoir')


def test_thinning_state_round_trips(tmp_path: Path) -> None:
    x, y = data(900)
    model = ExactGP(length=2.0, noise=1e-2, budget=120, warmup=50, min_variance=0.0)
    model.partial_fit(x[:500], y[:500])
    path = tmp_path / 'gp.npz'
    model.save(path)
    loaded = load_model(path)
    assert isinstance(loaded, ExactGP) and loaded.get_params() == model.get_params()
    assert loaded.get_params()['budget_rule'] == 'thin'
    np.testing.assert_allclose(loaded.partial_fit(x[500:], y[500:]),
                               model.partial_fit(x[500:], y[500:]), rtol=0, atol=1e-8)
    np.testing.assert_array_equal(loaded._positions[:loaded.n_points_],
                                  model._positions[:model.n_points_])
    assert loaded.stride_ == model.stride_ and loaded.n_evicted_ == model.n_evicted_ > 0
