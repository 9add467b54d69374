"""The RLS trainer of a physical model inside the online identifier, as the node would run it."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.identification import OnlineIdentifier
from scara_ident_ros.identification.rls_trainer import RecursiveLeastSquaresTrainer

URDF = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'
FRICTION = [3.0, 1.5, 20.0, 0.05, 6.0, 3.0, 15.0, 0.5]  # viscous, then Coulomb


def test_online_identifier_learns_a_physical_model_by_rls() -> None:
    truth = PhysicalModel.from_urdf_file(URDF)
    theta = truth.urdf_parameters()
    theta[truth.n_base:] = FRICTION
    truth.set_theta(theta)
    rate_hz, count = 1000.0, 3000
    t = np.arange(count) / rate_hz
    omega = np.array([[2.0, 3.1, 2.5, 4.0], [5.3, 1.7, 3.9, 6.1]])  # rad/s
    amp = np.array([[0.8, 0.9, 0.05, 2.0], [0.3, 0.4, 0.03, 0.8]])
    arg = omega[:, None, :] * t[None, :, None]
    q = np.array([0.0, 0.0, 0.1, 0.0]) + (amp[:, None, :] * np.sin(arg)).sum(axis=0)
    qd = (amp[:, None, :] * omega[:, None, :] * np.cos(arg)).sum(axis=0)
    qdd = -(amp[:, None, :] * omega[:, None, :] ** 2 * np.sin(arg)).sum(axis=0)
    effort = truth.predict(np.hstack([q, qd, qdd]))
    stamps = 1_000_000_000 + np.round(t * 1e9).astype(np.int64)
    names = truth.joint_names

    model = PhysicalModel.from_urdf_file(URDF)
    trainer = RecursiveLeastSquaresTrainer(model, p0=1e9)
    online = OnlineIdentifier(model, joint_names=names, trainer=trainer)
    for k in range(count):
        online.process(int(stamps[k]), names, q[k], qd[k], effort[k])
    online.finish()
    assert online.counts.learnt == trainer.rls.count == count
    # q'' is estimated (centred fit of q'): the friction comes out within 2 %
    np.testing.assert_allclose(model.theta[model.n_base:], FRICTION, rtol=0.02, atol=0.01)
    # the a-priori errors of the last window are a small fraction of the efforts
    assert online.errors.snapshot().nmse_total < 1e-3
