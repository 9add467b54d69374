"""Data sets from the simulator: inputs [q, q', q''], true or estimated q''."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.experiments import (Dataset, dataset_from_record, estimate_acceleration,
                                         make_dataset, simulate_record)
from scara_ident_ros.identification import Differentiator
from scara_ident_ros.sim import SimRecord

PARAMS = ScaraParams()


@pytest.fixture(scope='module')
def record() -> SimRecord:
    return simulate_record(PARAMS, seconds=1.0, seed=3)


def test_true_acceleration_dataset_stacks_q_qd_qdd(record: SimRecord) -> None:
    data = dataset_from_record(record, acceleration='true', name='train')
    assert len(data) == 1000 and data.n_joints == 4 and data.acceleration == 'true'
    np.testing.assert_array_equal(data.X, np.hstack([record.q, record.qd, record.qdd]))
    np.testing.assert_array_equal(data.Y, record.effort)
    assert data.seconds == pytest.approx(0.999)


def test_estimated_acceleration_drops_the_warm_up_and_follows_the_true_one(
        record: SimRecord) -> None:
    data = dataset_from_record(record, acceleration='estimated')
    assert len(data) == 999 and data.acceleration == 'estimated'
    np.testing.assert_array_equal(data.stamp_ns, record.stamp_ns[1:])
    qdd = data.X[:, 8:]
    # a 50 Hz low-pass lags by ~3 ms: close to, not equal to, the true acceleration
    error = np.sqrt(np.mean((qdd[200:] - record.qdd[201:]) ** 2, axis=0))
    assert np.all(error < 0.1 * record.qdd.std(axis=0))
    assert np.all(error > 0.0)


def test_estimate_acceleration_is_the_differentiator_sample_by_sample(
        record: SimRecord) -> None:
    diff = Differentiator('backward')
    acc = estimate_acceleration(record.stamp_ns, record.qd, differentiator=diff)
    assert np.all(np.isnan(acc[0]))
    np.testing.assert_allclose(acc[1:], np.diff(record.qd, axis=0) / 1e-3, rtol=1e-9)


def test_head_and_subsample(record: SimRecord) -> None:
    data = dataset_from_record(record)
    head = data.head(0.25)
    assert len(head) == 250
    sub = data.subsample(100, seed=1)
    assert len(sub) == 100 and np.all(np.diff(sub.stamp_ns) > 0)
    assert np.array_equal(sub.X, data.subsample(100, seed=1).X)
    assert data.subsample(5000) is data


def test_make_dataset_checks_shapes() -> None:
    with pytest.raises(ValueError, match='X \\(N, 3n\\)'):
        Dataset(np.arange(3), np.zeros((3, 5)), np.zeros((3, 2)))
    data = make_dataset(np.arange(4) * 1_000_000, np.zeros((4, 2)), np.ones((4, 2)),
                        np.ones((4, 2)), qdd=np.zeros((4, 2)))
    assert data.X.shape == (4, 6)
