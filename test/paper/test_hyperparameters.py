"""The grid search: honest a-priori scores, divergence, choice, network construction."""
from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.paper.datasets import simulate_dataset
from scara_ident_ros.paper.hyperparameters import Grid, Hyperparameters, search
from scara_ident_ros.nn.presets import METHODS, make_network
from robot_scaling import robot_scaling  # test/robot_scaling.py

PARAMS = ScaraParams()
SCALING = robot_scaling(PARAMS)


@pytest.fixture(scope='module')
def segment() -> Dataset:
    return simulate_dataset(PARAMS, seconds=1.0, seed=0, acceleration='estimated')


def test_defaults_are_the_methods_table() -> None:
    for name, spec in METHODS.items():
        h = Hyperparameters.defaults(name)
        assert (h.learning_rate, h.momentum, h.weight_scale) == (
            spec.learning_rate, spec.momentum, spec.weight_scale)


def test_make_network_uses_the_hyperparameters() -> None:
    net = make_network('ffw', 4, seed=4, **asdict(Hyperparameters(0.2, 0.3, 1.5)))
    assert (net.n_inputs, net.n_hidden, net.n_outputs) == (12, 40, 4)
    assert net.activation == 'slog' and net.seed == 4
    assert (net.learning_rate, net.momentum, net.weight_scale) == (0.2, 0.3, 1.5)


def test_search_scores_every_point_and_picks_the_lowest(segment: Dataset) -> None:
    grid = Grid(learning_rate=(1e-4, 0.05, 0.1), momentum=(0.5,), weight_scale=(2.0,))
    result = search('ffs', segment.X, segment.Y, scaling=SCALING, grid=grid, seeds=(0,))
    assert [t.hyperparameters for t in result.trials] == grid.points()
    # 1e-4 is worse than the mean a priori, 0.1 is the top rate (no margin known)
    assert [t.eligible for t in result.trials] == [False, True, False]
    assert result.best.learning_rate == 0.05  # a tiny step barely learns in 0.5 s
    assert result.n_scored == round(0.5 * len(segment))
    # both figures recomputed by hand: frozen copy at the split, then a-priori errors
    net = make_network('ffs', 4, **asdict(result.best))
    net.set_scaling(*SCALING)
    n_fit = len(segment) - result.n_scored
    net.partial_fit(segment.X[:n_fit], segment.Y[:n_fit])
    frozen = segment.Y[n_fit:] - net.predict(segment.X[n_fit:])
    a_priori = net.partial_fit(segment.X[n_fit:], segment.Y[n_fit:])
    var = segment.Y[n_fit:].var(axis=0)
    trial = result.best_trial
    assert trial is not None
    assert trial.score == pytest.approx(np.mean(np.mean(a_priori ** 2, axis=0) / var),
                                        rel=1e-12)
    assert trial.frozen == pytest.approx(np.mean(np.mean(frozen ** 2, axis=0) / var),
                                         rel=1e-12)


def test_a_point_next_to_divergence_is_not_eligible(segment: Dataset) -> None:
    grid = Grid(learning_rate=(0.02, 0.05, 1e6), momentum=(0.9,), weight_scale=(2.0,))
    result = search('ffmw', segment.X, segment.Y, scaling=SCALING, grid=grid)
    low, mid, high = result.trials
    assert math.isinf(high.score) and high.diverged and not high.eligible
    assert not mid.eligible and low.eligible
    assert result.best.learning_rate == 0.02


def test_the_score_is_the_worst_seed(segment: Dataset) -> None:
    grid = Grid(learning_rate=(0.05,), momentum=(0.5,), weight_scale=(2.0,))
    both = search('ffw', segment.X, segment.Y, scaling=SCALING, grid=grid, seeds=(0, 1))
    single = [search('ffw', segment.X, segment.Y, scaling=SCALING, grid=grid, seeds=(s,))
              for s in (0, 1)]
    trial = both.trials[0]
    assert trial.scores == (single[0].trials[0].score, single[1].trials[0].score)
    assert trial.score == max(trial.scores) and both.seeds == (0, 1)
    # a single learning rate gives no margin: the lowest finite score still wins
    assert not trial.eligible and both.best == trial.hyperparameters


def test_all_diverged_falls_back_to_the_defaults(segment: Dataset) -> None:
    grid = Grid(learning_rate=(1e6,), momentum=(0.9,), weight_scale=(2.0,))
    result = search('ffw', segment.X, segment.Y, scaling=SCALING, grid=grid)
    assert result.best == Hyperparameters.defaults('ffw') and result.best_trial is None


def test_grid_points_and_size() -> None:
    grid = Grid((0.1, 0.2), (0.0, 0.9), (1.0,))
    assert grid.size == 4 == len(grid.points())
    assert grid.points()[1] == Hyperparameters(0.1, 0.9, 1.0)
