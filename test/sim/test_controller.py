"""Tests of the computed-torque controller."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ParamError, ScaraParams
from scara_ident_ros.sim.controller import ComputedTorqueController

MODEL = ScaraModel(ScaraParams())


def test_law_is_inverse_dynamics_of_the_commanded_acceleration() -> None:
    rng = np.random.default_rng(0)
    q, qd, q_des, qd_des = rng.normal(0.0, 0.1, (4, 30, 4))
    qdd_des = rng.normal(0.0, 1.0, (30, 4))
    kp, kd = np.array([100.0, 200.0, 300.0, 400.0]), np.array([20.0, 28.0, 35.0, 40.0])
    ctrl = ComputedTorqueController(MODEL, kp, kd, effort_max=(1e6,) * 4)
    expected = MODEL.inverse_dynamics(q, qd, qdd_des + kd * (qd_des - qd) + kp * (q_des - q))
    tau = ctrl.compute(q, qd, q_des, qd_des, qdd_des)
    np.testing.assert_allclose(tau, expected, rtol=1e-12)
    for i in range(30):
        np.testing.assert_allclose(ctrl.compute_single(q[i], qd[i], q_des[i], qd_des[i],
                                                       qdd_des[i]), expected[i], rtol=1e-12)
    np.testing.assert_allclose(ctrl.compute(q[3], qd[3], q_des[3], qd_des[3], qdd_des[3]),
                               expected[3], rtol=1e-12)


def test_efforts_are_clipped_to_the_limits() -> None:
    ctrl = ComputedTorqueController(MODEL, 400.0, 40.0)
    limit = np.array(MODEL.params.effort_max)
    far = np.array([10.0, 10.0, 10.0, 40.0])          # joint 4 needs more than links 1 + 2
    tau = ctrl.compute(np.zeros(4), np.zeros(4), far, np.zeros(4), np.zeros(4))
    np.testing.assert_array_equal(tau, limit)
    single = ctrl.compute_single(np.zeros(4), np.zeros(4), -far, np.zeros(4), np.zeros(4))
    np.testing.assert_array_equal(single, -limit)


def test_scalar_gains_apply_to_every_joint_and_bad_gains_fail() -> None:
    ctrl = ComputedTorqueController(MODEL, 100.0, 20.0)
    assert ctrl.kp == (100.0,) * 4 and ctrl.kd == (20.0,) * 4
    with pytest.raises(ParamError, match='kp'):
        ComputedTorqueController(MODEL, -1.0, 20.0)
    with pytest.raises(ParamError, match=r'kd\[2\] must be > 0'):
        ComputedTorqueController(MODEL, 1.0, (1.0, 1.0, 0.0, 1.0))
