"""Tests of the linear-in-parameters form and of the least-squares identifier."""
from __future__ import annotations

import math

import numpy as np
import pytest

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ScaraParams
from scara_ident_ros.dynamics.regressor import (N_PARAMETERS, PARAMETER_NAMES,
                                                LeastSquaresIdentifier, base_parameters,
                                                regressor)


def states(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = rng.uniform(-math.pi, math.pi, (n, 4))
    return q, rng.normal(0.0, 2.0, (n, 4)), rng.normal(0.0, 10.0, (n, 4))


def test_names_and_shapes() -> None:
    assert N_PARAMETERS == len(PARAMETER_NAMES) == 14
    assert base_parameters(ScaraParams()).shape == (14,)
    rng = np.random.default_rng(0)
    q, qd, qdd = states(rng, 7)
    assert regressor(q, qd, qdd).shape == (7, 4, 14)
    assert regressor(q[0], qd[0], qdd[0]).shape == (4, 14)


@pytest.mark.parametrize('seed', range(3))
def test_regressor_times_theta_is_inverse_dynamics(seed: int) -> None:
    rng = np.random.default_rng(seed)
    params = ScaraParams(m1=rng.uniform(1, 10), m4=rng.uniform(0.5, 5), lc2=0.05,
                         izz4=rng.uniform(0.001, 0.05), gravity=9.80665,
                         coulomb_eps=rng.uniform(0.01, 0.1),
                         viscous=tuple(rng.uniform(0, 3, 4)), coulomb=tuple(rng.uniform(0, 3, 4)))
    q, qd, qdd = states(rng, 100)
    tau = ScaraModel(params).inverse_dynamics(q, qd, qdd)
    ymat = regressor(q, qd, qdd, coulomb_eps=params.coulomb_eps)
    np.testing.assert_allclose(ymat @ base_parameters(params), tau, rtol=1e-12,
                               atol=1e-12 * np.abs(tau).max())


def test_least_squares_recovers_theta_from_noise_free_simulated_data() -> None:
    params = ScaraParams()
    model = ScaraModel(params)
    rng = np.random.default_rng(4)
    # a short excitation: sums of sines on every joint
    t = np.linspace(0.0, 10.0, 2001)[:, None]
    freqs, phases = rng.uniform(0.1, 1.0, (3, 4)), rng.uniform(0, 2 * math.pi, (3, 4))
    amps = np.array([0.5, 0.6, 0.03, 1.0])
    q = np.zeros((t.shape[0], 4))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    for f, ph in zip(freqs, phases):
        w = 2 * math.pi * f
        q += amps * np.sin(w * t + ph)
        qd += amps * w * np.cos(w * t + ph)
        qdd -= amps * w ** 2 * np.sin(w * t + ph)
    q[:, 2] += 0.1
    tau = model.inverse_dynamics(q, qd, qdd)
    ident = LeastSquaresIdentifier(coulomb_eps=params.coulomb_eps).fit(q, qd, qdd, tau)
    np.testing.assert_allclose(ident.theta_, base_parameters(params), rtol=1e-8, atol=1e-9)
    assert ident.residual_rms_.max() < 1e-8
    np.testing.assert_allclose(ident.predict(q[:5], qd[:5], qdd[:5]), tau[:5], rtol=1e-9)


def test_identifier_errors() -> None:
    ident = LeastSquaresIdentifier()
    with pytest.raises(RuntimeError, match='before fit'):
        ident.predict(np.zeros(4), np.zeros(4), np.zeros(4))
    z = np.zeros((10, 4))
    with pytest.raises(ValueError, match='tau must have shape'):
        ident.fit(z, z, z, np.zeros((9, 4)))
    with pytest.raises(ValueError, match='coulomb_eps'):
        regressor(z, z, z, coulomb_eps=0.0)
