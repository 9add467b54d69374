"""Online learning over a stream: a-priori predictions, windows, divergence."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.paper.datasets import simulate_dataset
from scara_ident_ros.paper.table3 import hold_rows, learn_online, online_rows, run_online
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn import FeedForwardNet
from robot_scaling import robot_scaling  # test/robot_scaling.py

PARAMS = ScaraParams()
SCALING = robot_scaling(PARAMS)


@pytest.fixture(scope='module')
def stream() -> Dataset:
    return simulate_dataset(PARAMS, seconds=1.5, seed=0, acceleration='estimated')


def _net(**hyper: float) -> FeedForwardNet:
    net = make_network('ffmw', 4, seed=1, **{'learning_rate': 0.05, 'momentum': 0.5,
                                              'weight_scale': 2.0, **hyper})
    net.set_scaling(*SCALING)
    return net


def test_predictions_are_a_priori(stream: Dataset) -> None:
    net, twin = _net(), _net()
    trace = learn_online(net, stream.X[:50], stream.Y[:50], chunk=7)
    assert trace.learnt == 50 and trace.diverged_at is None
    # the twin predicts each sample before learning it, one sample at a time
    for x, y, predicted in zip(stream.X[:50], stream.Y[:50], trace.predicted):
        np.testing.assert_allclose(predicted, twin.predict(x), rtol=1e-10, atol=1e-12)
        twin.partial_fit(x, y)
    np.testing.assert_allclose(net.get_theta(), twin.get_theta(), rtol=1e-12)


def test_online_learning_lowers_the_error(stream: Dataset) -> None:
    trace = learn_online(_net(), stream.X, stream.Y)
    early = np.mean((stream.Y[:300] - trace.predicted[:300]) ** 2)
    late = np.mean((stream.Y[-300:] - trace.predicted[-300:]) ** 2)
    assert late < 0.1 * early


def test_divergence_stops_learning_and_leaves_nan(stream: Dataset) -> None:
    trace = learn_online(_net(learning_rate=1e8), stream.X, stream.Y, chunk=100)
    assert trace.diverged_at is not None and trace.learnt == trace.diverged_at
    assert np.all(np.isnan(trace.predicted[trace.diverged_at:]))
    rows = online_rows('FFMW', 1, trace, stream.Y, {'held-out': (stream.X, stream.Y)},
                       window=500)
    assert all(r.diverged and np.isnan(r.nmse_mean) for r in rows)
    assert 'diverged' in rows[0].note


def test_rows_cover_the_last_100_the_window_and_held_out(stream: Dataset) -> None:
    test = simulate_dataset(PARAMS, seconds=0.3, seed=1, acceleration='estimated')
    rows = run_online(stream.X, stream.Y, {'held-out': (test.X, test.Y)}, scaling=SCALING,
                      methods=['ffw'], seeds=[0, 3], window=400)
    assert [(r.seed, r.data, r.n_samples) for r in rows] == [
        (s, d, n) for s in (0, 3)
        for d, n in (('stream-last-100', 100), ('stream-last-400', 400),
                     ('held-out', len(test)))]
    assert all(r.table == 'online' and r.method == 'FFW' for r in rows)
    assert rows[0].iterations == len(stream)


def test_hold_baseline_predicts_the_previous_effort() -> None:
    Y = np.array([[0.0, 1.0], [1.0, 1.0], [3.0, 2.0], [6.0, 2.0], [10.0, 5.0]])
    short, long = hold_rows(Y, window=4, paper_window=2)
    assert (short.method, short.data, long.data) == ('hold', 'stream-last-2', 'stream-last-4')
    # errors over the last 4: joint 1: 1, 2, 3, 4; joint 2: 0, 1, 0, 3
    np.testing.assert_allclose(long.mse, [30 / 4, 10 / 4])
    np.testing.assert_allclose(short.mse, [25 / 2, 9 / 2])
