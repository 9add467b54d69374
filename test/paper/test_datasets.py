"""Data sets from the simulator: inputs [q, q', q''], true or estimated q''."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification.dataset import make_dataset
from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record
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


def test_estimated_acceleration_is_zero_lag_and_keeps_every_sample(record: SimRecord) -> None:
    data = dataset_from_record(record, acceleration='estimated')
    assert len(data) == 1000 and data.acceleration == 'estimated'
    np.testing.assert_array_equal(data.stamp_ns, record.stamp_ns)
    qdd = data.X[:, 8:]
    # Centred: no lag, closer to the true q'' than the causal 50 Hz low-pass (neither follows
    # the jumps of q'' where Coulomb friction changes sign: q' has a kink there).
    error = np.sqrt(np.mean((qdd[200:] - record.qdd[200:]) ** 2, axis=0))
    lowpass = make_dataset(record.stamp_ns, record.q, record.qd, record.effort,
                           differentiator=Differentiator('lowpass', cutoff_hz=50.0))
    lagged = np.sqrt(np.mean((lowpass.X[199:, 8:] - record.qdd[200:]) ** 2, axis=0))
    assert np.all(error < 0.05 * record.qdd.std(axis=0))
    assert np.all(error < lagged)


def test_causal_estimate_drops_the_warm_up_sample(record: SimRecord) -> None:
    data = make_dataset(record.stamp_ns, record.q, record.qd, record.effort,
                        differentiator=Differentiator('backward'))
    np.testing.assert_array_equal(data.stamp_ns, record.stamp_ns[1:])
    np.testing.assert_allclose(data.X[:, 8:], np.diff(record.qd, axis=0) / 1e-3, rtol=1e-9)


def test_head_and_subsample(record: SimRecord) -> None:
    data = dataset_from_record(record)
    head = data.head(0.25)
    assert len(head) == 250
    sub = data.subsample(100, seed=1)
    assert len(sub) == 100 and np.all(np.diff(sub.stamp_ns) > 0)
    assert np.array_equal(sub.X, data.subsample(100, seed=1).X)
    assert data.subsample(5000) is data

