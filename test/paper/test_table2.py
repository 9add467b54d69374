"""Offline LM training rows: iterations, goal bookkeeping, evaluations."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.paper.datasets import simulate_dataset
from scara_ident_ros.paper.table2 import fit_offline, goal_iteration, offline_rows, run_offline
from scara_ident_ros.nn import FitHistory

PARAMS = ScaraParams()


@pytest.fixture(scope='module')
def data() -> tuple[Dataset, Dataset]:
    train = simulate_dataset(PARAMS, seconds=2.0, seed=0).subsample(150)
    test = simulate_dataset(PARAMS, seconds=0.5, seed=1)
    return train, test


def test_goal_iteration_is_the_first_iteration_at_or_below_the_goal() -> None:
    history = FitHistory(algorithm='lm', mse=[1.0, 0.1, 1e-3, 1e-5, 1e-6], iterations=4)
    assert goal_iteration(history, 1e-5) == 3
    assert goal_iteration(history, 2.0) == 0
    assert goal_iteration(history, 1e-9) is None


def test_fit_offline_trains_with_lm_to_the_iteration_limit(data: tuple[Dataset, Dataset]) -> None:
    train, _ = data
    fit = fit_offline('ffs', train.X, train.Y, seed=2, iterations=4)
    assert fit.history.algorithm == 'lm' and fit.history.iterations == 4
    assert fit.history.mse[-1] < fit.history.mse[0]
    assert fit.network.activation == 'sigmoid' and fit.network.seed == 2
    assert fit.seconds > 0.0 and fit.n_samples == 150
    # default scaling: the training data's min-max
    np.testing.assert_allclose(fit.network.y_scaling.lo, train.Y.min(axis=0))


def test_rows_evaluate_each_data_set_with_the_trained_network(
        data: tuple[Dataset, Dataset]) -> None:
    train, test = data
    fit = fit_offline('ffmw', train.X, train.Y, iterations=3)
    rows = offline_rows(fit, {'train': (train.X, train.Y), 'held-out': (test.X, test.Y)},
                        goal=1e-30)
    assert [r.data for r in rows] == ['train', 'held-out']
    prediction = fit.network.predict(test.X)
    mse = np.mean((test.Y - prediction) ** 2, axis=0)
    np.testing.assert_allclose(rows[1].mse, mse)
    np.testing.assert_allclose(rows[1].nmse, mse / test.Y.var(axis=0))
    assert rows[0].method == 'FFMW' and rows[0].iterations == 3 and not rows[0].goal_reached
    # the training-set MSE in scaled units is the history's last figure
    half_range = (train.Y.max(axis=0) - train.Y.min(axis=0)) / 2
    scaled = np.mean(np.array(rows[0].mse) / half_range ** 2)
    assert scaled == pytest.approx(fit.history.mse[-1], rel=1e-9)


def test_run_offline_gives_a_row_per_method_seed_and_data_set(
        data: tuple[Dataset, Dataset]) -> None:
    train, test = data
    messages: list[str] = []
    rows = run_offline(train.X, train.Y, {'held-out': (test.X, test.Y)},
                       methods=['ffw', 'ffs'], seeds=[0, 1], iterations=2, goal=1.0,
                       progress=messages.append)
    assert [(r.method, r.seed, r.data) for r in rows] == [
        (m, s, d) for m in ('FFW', 'FFS') for s in (0, 1) for d in ('train', 'held-out')]
    assert all(r.goal == 1.0 and r.goal_reached for r in rows)
    assert len(messages) == 4
