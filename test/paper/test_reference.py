"""The least-squares reference: a real check of the data pipeline on noise-free data."""
from __future__ import annotations

import numpy as np

from scara_ident_ros.dynamics import ScaraParams, base_parameters
from scara_ident_ros.paper.datasets import simulate_dataset
from scara_ident_ros.paper.reference import fit_reference, online_reference_rows, reference_rows
from scara_ident_ros.paper.table3 import stream_data_names
from scara_ident_ros.paper.reference import is_scara

PARAMS = ScaraParams()


def test_ls_recovers_the_noise_free_simulated_efforts() -> None:
    train = simulate_dataset(PARAMS, seconds=5.0, seed=0).subsample(1000)
    test = simulate_dataset(PARAMS, seconds=2.0, seed=1)
    rows = reference_rows(train.X, train.Y, {'held-out': (test.X, test.Y)})
    assert [r.data for r in rows] == ['train', 'held-out']
    for row in rows:
        assert row.method == 'LS' and row.seed is None and row.table == 'offline'
        assert row.nmse_mean < 1e-18
        assert max(row.mse) < 1e-18
    # ... because it finds the simulator's own base parameters
    fit = fit_reference(train.X, train.Y)
    np.testing.assert_allclose(fit.identifier.theta_, base_parameters(PARAMS), rtol=1e-8)


def test_online_reference_rows_fit_before_the_windows() -> None:
    stream = simulate_dataset(PARAMS, seconds=3.0, seed=0, acceleration='estimated')
    rows = online_reference_rows(stream.X, stream.Y, window=1000)
    short, long = stream_data_names(1000, 100)
    assert [r.data for r in rows] == [short, long]
    assert rows[0].n_samples == 100 and rows[1].n_samples == 1000
    assert 'first 2000 stream samples' in rows[0].note  # every sample (zero-phase q'')
    # estimated q'' lags the true one: good, not exact
    assert 1e-12 < rows[1].nmse_mean < 0.1


def test_is_scara_needs_its_joint_names_and_limits() -> None:
    simulated = simulate_dataset(PARAMS, seconds=2.0, seed=0)
    names = PARAMS.joint_names
    assert is_scara(names, simulated.X)
    assert not is_scara(('a', 'b', 'c', 'd'), simulated.X)  # another robot's joints
    assert not is_scara(names[::-1], simulated.X)
    beyond = simulated.X.copy()
    beyond[5, 2] = PARAMS.position_max[2] + 0.5  # joint3, the quill, 0.5 m too far
    assert not is_scara(names, beyond)
    assert not is_scara(names, simulated.X[:, :9])  # not 4 joints
