"""Computed-torque (inverse-dynamics) trajectory tracking controller.

    τ = M(q) (q''_d + Kd e' + Kp e) + C(q, q') q' + G(q) + F(q'),   e = q_d − q,

clipped to the actuator limits. With a perfect model the closed loop is the decoupled linear
error dynamics e'' + Kd e' + Kp e = 0 (critically damped for Kd = 2 √Kp). A model mismatch
is obtained by giving the controller a model built from other parameters than the plant's,
e.g. ``ScaraModel(params.perturbed(0.1, seed=1))``.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from scara_ident_ros.dynamics.model import ScaraModel, _as_states
from scara_ident_ros.dynamics.params import _vector4

__all__ = ['ComputedTorqueController']


class ComputedTorqueController:
    """Inverse-dynamics controller with PD feedback on the tracking error.

    Parameters
    ----------
    model : ScaraModel
        The model the controller believes in (may differ from the simulated plant).
    kp : float or sequence of 4 float
        Proportional gains (1/s²), > 0.
    kd : float or sequence of 4 float
        Derivative gains (1/s), > 0.
    effort_max : sequence of 4 float, optional
        Symmetric effort limits (N·m, N); default ``model.params.effort_max``.

    Raises
    ------
    ParamError
        If a gain or a limit is not a positive finite number.
    """

    def __init__(self, model: ScaraModel, kp: float | Sequence[float],
                 kd: float | Sequence[float], *,
                 effort_max: Sequence[float] | None = None) -> None:
        self.model = model
        self.kp = _vector4('kp', kp, minimum=0.0, allow_scalar=True)
        self.kd = _vector4('kd', kd, minimum=0.0, allow_scalar=True)
        limits = model.params.effort_max if effort_max is None else effort_max
        self.effort_max = _vector4('effort_max', limits, minimum=0.0)
        self._kp = np.array(self.kp)
        self._kd = np.array(self.kd)
        self._limit = np.array(self.effort_max)

    def compute(self, q: np.ndarray, qd: np.ndarray, q_des: np.ndarray, qd_des: np.ndarray,
                qdd_des: np.ndarray) -> np.ndarray:
        """Efforts within ±effort_max (N·m, N·m, N, N·m) for measured q, qd and desired
        q_des, qd_des, qdd_des, each (4,) or (N, 4) in SI; the result has their shape."""
        (q, qd, q_des, qd_des, qdd_des), single = _as_states(q, qd, q_des, qd_des, qdd_des)
        command = qdd_des + self._kd * (qd_des - qd) + self._kp * (q_des - q)
        tau = np.clip(self.model.inverse_dynamics(q, qd, command), -self._limit, self._limit)
        return tau[0] if single else tau

    def compute_single(self, q: Sequence[float], qd: Sequence[float],
                       q_des: Sequence[float], qd_des: Sequence[float],
                       qdd_des: Sequence[float]) -> tuple[float, float, float, float]:
        """Same as :meth:`compute` for one state, in plain Python floats (fast path)."""
        kp, kd = self.kp, self.kd
        command = [qdd_des[i] + kd[i] * (qd_des[i] - qd[i]) + kp[i] * (q_des[i] - q[i])
                   for i in range(4)]
        tau = self.model.inverse_dynamics_single(q, qd, command)
        limit = self.effort_max
        return (min(max(tau[0], -limit[0]), limit[0]), min(max(tau[1], -limit[1]), limit[1]),
                min(max(tau[2], -limit[2]), limit[2]), min(max(tau[3], -limit[3]), limit[3]))
