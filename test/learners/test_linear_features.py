"""The linear baseline: exact on efforts linear in its features, and its file round-trips."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.estimator import load_model
from scara_ident_ros.learners.linear_features import LinearFeatures, linear_features
from scara_ident_ros.nn.errors import ModelFormatError
from scara_ident_ros.nn.model_file import write_model


def samples(n: int = 3, rows: int = 400, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.hstack([rng.uniform(-2.0, 2.0, (rows, n)), rng.normal(0.0, 0.3, (rows, n)),
                      rng.normal(0.0, 4.0, (rows, n))])


def test_features_are_the_documented_columns() -> None:
    X = samples(2, 5)
    F = linear_features(X)
    q, qd = X[:, :2], X[:, 2:4]
    assert F.shape == (5, 13)
    np.testing.assert_array_equal(F[:, :6], X)
    np.testing.assert_allclose(F[:, 6:8], np.sin(q))
    np.testing.assert_allclose(F[:, 8:10], np.cos(q))
    np.testing.assert_allclose(F[:, 10:12], np.tanh(qd / 0.05))
    np.testing.assert_array_equal(F[:, 12], 1.0)


def test_recovers_efforts_linear_in_the_features_and_nothing_else() -> None:
    X, Xt = samples(), samples(seed=1)
    coef = np.random.default_rng(2).normal(size=(19, 3))
    model = LinearFeatures().fit(X, linear_features(X) @ coef)
    np.testing.assert_allclose(model.coef_, coef, rtol=1e-8, atol=1e-8)
    assert model.score(Xt, linear_features(Xt) @ coef) == pytest.approx(1.0)
    # an effort it cannot represent (a product of joints) is not fitted exactly
    Y = X[:, :1] * X[:, 1:2] * X[:, 3:4]
    assert LinearFeatures().fit(X, Y).score(Xt, Xt[:, :1] * Xt[:, 1:2] * Xt[:, 3:4]) < 0.5


def test_file_round_trip_and_refusals(tmp_path: Path) -> None:
    X = samples()
    model = LinearFeatures().fit(X, np.sin(X[:, :3]) + X[:, 6:])
    model.metadata['joint_names'] = np.array(['a', 'b', 'c'])
    model.save(tmp_path / 'm.npz')
    same = load_model(tmp_path / 'm.npz')
    assert type(same) is LinearFeatures and same.joint_names == ('a', 'b', 'c')
    np.testing.assert_array_equal(same.predict(X), model.predict(X))
    write_model(tmp_path / 'bad.npz', {'coef': np.zeros((8, 3))}, {}, kind='linear')
    with pytest.raises(ModelFormatError, match='not a linear model'):
        load_model(tmp_path / 'bad.npz')
    with pytest.raises(RuntimeError, match='learnt nothing'):
        LinearFeatures().predict(X)
    with pytest.raises(ValueError, match='3n columns'):
        LinearFeatures().fit(X[:, :4], X[:, :1])


def test_partial_fit_predicts_before_learning_and_ends_at_the_batch_solution(
        tmp_path: Path) -> None:
    """In calls of any size, each call's rows predicted with what came before; after every
    call the coefficients are fit's on all rows so far; a saved model goes on learning."""
    X = samples(rows=900)
    Y = np.sin(X[:, :3]) * 3.0 + X[:, 3:6] * X[:, :3] + np.random.default_rng(3).normal(
        0.0, 0.1, (900, 3))
    online = LinearFeatures()
    first = online.partial_fit(X[:100], Y[:100])
    np.testing.assert_array_equal(first, 0.0)  # nothing learnt before the first call
    np.testing.assert_allclose(online.coef_, LinearFeatures().fit(X[:100], Y[:100]).coef_,
                               rtol=1e-7, atol=1e-8)
    before = LinearFeatures().fit(X[:100], Y[:100])
    predicted = online.partial_fit(X[100:101], Y[100:101])
    np.testing.assert_allclose(predicted, before.predict(X[100:101]), rtol=1e-9)
    online.save(tmp_path / 'linear.npz')
    resumed = load_model(tmp_path / 'linear.npz')
    assert isinstance(resumed, LinearFeatures)
    for start, stop in ((101, 400), (400, 407), (407, 900)):
        for model in (online, resumed):
            model.partial_fit(X[start:stop], Y[start:stop])
        batch = LinearFeatures().fit(X[:stop], Y[:stop])
        np.testing.assert_allclose(online.coef_, batch.coef_, rtol=1e-7, atol=1e-8)
        np.testing.assert_allclose(resumed.coef_, online.coef_, rtol=1e-9, atol=1e-12)
    # fit then partial_fit: the same as learning everything at once
    continued = LinearFeatures().fit(X[:500], Y[:500])
    continued.partial_fit(X[500:], Y[500:])
    np.testing.assert_allclose(continued.coef_, batch.coef_, rtol=1e-7, atol=1e-8)
    with pytest.raises(ValueError, match='maps 9 inputs to 3 outputs'):
        online.partial_fit(X[:5, :6], Y[:5, :2])
