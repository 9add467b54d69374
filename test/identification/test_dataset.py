"""Samples from joint states: the same inputs as the online identifier, shapes checked."""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.identification import Differentiator, OnlineIdentifier
from scara_ident_ros.identification.dataset import (Dataset, dataset_from_joint_states,
                                                    make_dataset)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'bag'))
from fake_bags import States, synthetic_states  # noqa: E402  (not a package)


class _Recorder:
    """A model that remembers its inputs and learns nothing."""

    def __init__(self, n: int) -> None:
        self.n_inputs, self.n_outputs = 3 * n, n
        self.inputs: list[np.ndarray] = []

    def predict(self, X: np.ndarray) -> np.ndarray:
        self.inputs.append(np.array(X))
        return np.zeros(self.n_outputs)

    def partial_fit(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        self.inputs.append(np.array(X[0]))  # the a-priori prediction inside the step
        return np.array(Y, dtype=float)  # a-priori error of a zero prediction


def _damaged(states: States) -> States:
    """Insert a NaN, a repeated stamp, a gap and a shuffled pair into the stream."""
    position = states.position.copy()
    position[10, 0] = np.nan
    stamps = states.stamp_ns.copy()
    stamps[20] = stamps[19]
    stamps[300:] += 50_000_000  # 50 ms gap: the differentiator restarts
    order = np.arange(stamps.shape[0])
    order[[40, 41]] = order[[41, 40]]  # out of order in the recording, sorted by stamp
    return States(stamps[order], states.names, position[order], states.velocity[order],
                  states.effort[order])


@pytest.mark.parametrize('n_joints', [2, 6])
def test_inputs_equal_the_online_identifiers(n_joints: int) -> None:
    states = _damaged(synthetic_states(n_joints, 0.5))
    recorded = dataset_from_joint_states(states)
    model = _Recorder(n_joints)
    online = OnlineIdentifier(model, joint_names=states.names)
    for i in np.argsort(states.stamp_ns, kind='stable'):
        online.process(int(states.stamp_ns[i]), states.names, states.position[i],
                       states.velocity[i], states.effort[i])
    assert online.counts.pending == online.lag == 10  # the zero-phase estimate's 10 samples
    online.finish()
    assert online.counts.pending == 0
    assert recorded.names == states.names
    np.testing.assert_array_equal(recorded.data.X, np.array(model.inputs))
    assert len(recorded.data) == online.counts.predicted
    expected = {reason.value: n for reason, n in online.counts.skipped.items() if n}
    assert recorded.skipped == expected
    # Both histories (before and after the gap) are longer than the window: every valid
    # sample gets a q'' estimate (off-centre near the gap), none is lost to warm-up.
    assert expected == {'non_finite': 1, 'stamp_repeated': 1}
    assert len(recorded.data) == states.stamp_ns.shape[0] - 2
    assert recorded.data.acceleration == 'estimated'
    assert np.all(np.diff(recorded.data.stamp_ns) > 0)


def test_acceleration_tracks_the_true_one() -> None:
    states = synthetic_states(2, 2.0)
    data = dataset_from_joint_states(states).data
    q = data.X[:, :2]
    true_qdd = np.gradient(np.gradient(q, axis=0), axis=0) * 1e6  # 1 kHz
    # the centred estimate has no lag; np.gradient is one-sided at the ends
    error = np.abs(data.X[100:-5, 4:] - true_qdd[100:-5])
    assert error.max() < 0.01 * np.abs(true_qdd).max()


def test_no_effort_gives_no_samples() -> None:
    states = synthetic_states(2, 0.1)
    empty = dataclasses.replace(states, effort=np.zeros((states.stamp_ns.shape[0], 0)))
    recorded = dataset_from_joint_states(empty)
    assert len(recorded.data) == 0
    assert recorded.skipped == {'no_effort': states.stamp_ns.shape[0]}


def test_custom_differentiator_is_used() -> None:
    states = synthetic_states(2, 0.1)
    recorded = dataset_from_joint_states(states, differentiator=Differentiator('backward'))
    qd = states.velocity
    np.testing.assert_allclose(recorded.data.X[:, 4:], np.diff(qd, axis=0) * 1000.0)


def test_make_dataset_checks_shapes() -> None:
    with pytest.raises(ValueError, match='X \\(N, 3n\\)'):
        Dataset(np.arange(3), np.zeros((3, 5)), np.zeros((3, 2)))
    data = make_dataset(np.arange(4) * 1_000_000, np.zeros((4, 2)), np.ones((4, 2)),
                        np.ones((4, 2)), qdd=np.zeros((4, 2)))
    assert data.X.shape == (4, 6)
