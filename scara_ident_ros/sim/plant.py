"""The controlled robot over one sample: control law, dynamics and integrator of a simulator.

:class:`~scara_ident_ros.sim.simulator.Simulator` is robot-independent (stamps, jitter,
excitation, noise, disturbance); what it needs of the robot is a *plant*:

- ``control``: the computed-torque law with PD feedback on the tracking error,

      τ = clip(ID(q, q', q''_d + Kd (q'_d − q') + Kp (q_d − q)), ±effort_max),

  with ID the controller's inverse dynamics (friction included), so that with a perfect
  model the closed loop is e'' + Kd e' + Kp e = 0;
- ``step``: the true acceleration at the sample and the state one sample later, by
  ``substeps`` classical RK4 steps under the held effort.

Two plants share that contract and differ in their arithmetic only:

- :class:`ScaraPlant` works on plain Python floats (the SCARA's closed-form model is a few
  dozen float operations: array overheads would dominate);
- :class:`ArrayPlant` works on numpy arrays, for a dynamics object whose single-state
  calls take and return arrays (:class:`~scara_ident_ros.sim.pinocchio_robot.PinocchioRobot`:
  Pinocchio's ABA and RNEA in C++, so no Python loop runs over the joints).

A plant's vectors (its "native" type) are what the simulator stores and hands back to it;
:meth:`native` converts rows of an (N, n) array into them, :meth:`floats` converts one back
into a sequence of Python floats for a message.
"""
from __future__ import annotations

import operator
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import _vector
from scara_ident_ros.sim.controller import ComputedTorqueController

__all__ = ['Plant', 'ScaraPlant', 'ArrayPlant', 'ArrayDynamics']


class Plant(Protocol):
    """What :class:`~scara_ident_ros.sim.simulator.Simulator` needs of a robot."""

    n_joints: int
    effort_max: tuple[float, ...]

    def native(self, rows: np.ndarray) -> list[Any]:
        """Rows of an (N, n) array as N native vectors."""

    def floats(self, x: Any) -> Sequence[float]:
        """A native vector as a sequence of n Python floats."""

    def add(self, x: Any, y: Any) -> Any:
        """x + y element-wise, native."""

    def sub(self, x: Any, y: Any) -> Any:
        """x − y element-wise, native."""

    def control(self, q: Any, qd: Any, q_des: Any, qd_des: Any, qdd_des: Any) -> Any:
        """Clipped computed-torque efforts (N·m, N)."""

    def step(self, q: Any, qd: Any, tau: Any, h: float, substeps: int
             ) -> tuple[Any, Any, Any]:
        """``(qdd, q_next, qd_next)``: acceleration now, state after substeps of h (s)."""


class ScaraPlant:
    """The SCARA's closed-form model and controller, on tuples of 4 Python floats.

    Parameters
    ----------
    model : ScaraModel
        The true robot.
    controller : ComputedTorqueController
        The controller (its model may differ from the plant's).
    """

    def __init__(self, model: ScaraModel, controller: ComputedTorqueController) -> None:
        self.model = model
        self.controller = controller
        self.n_joints = len(controller.effort_max)
        self.effort_max = tuple(controller.effort_max)

    def native(self, rows: np.ndarray) -> list[Any]:
        return [tuple(row) for row in np.asarray(rows, dtype=float).tolist()]

    def floats(self, x: Any) -> Sequence[float]:
        return x

    def add(self, x: Any, y: Any) -> Any:
        return tuple(map(operator.add, x, y))

    def sub(self, x: Any, y: Any) -> Any:
        return tuple(map(operator.sub, x, y))

    def control(self, q: Any, qd: Any, q_des: Any, qd_des: Any, qdd_des: Any) -> Any:
        return self.controller.compute_single(q, qd, q_des, qd_des, qdd_des)

    def step(self, q: Any, qd: Any, tau: Any, h: float, substeps: int
             ) -> tuple[Any, Any, Any]:
        fd = self.model.forward_dynamics_single
        qdd = fd(q, qd, tau)
        q_next, qd_next = _rk4_floats(fd, q, qd, qdd, tau, h, substeps)
        return qdd, q_next, qd_next


class ArrayDynamics(Protocol):
    """Single-state dynamics on arrays of shape (n,): what :class:`ArrayPlant` integrates."""

    n_joints: int

    def forward_dynamics_single(self, q: np.ndarray, qd: np.ndarray,
                                tau: np.ndarray) -> np.ndarray:
        """Accelerations (n,) under the net efforts ``tau`` (n,)."""

    def inverse_dynamics_single(self, q: np.ndarray, qd: np.ndarray,
                                qdd: np.ndarray) -> np.ndarray:
        """Efforts (n,) that give the accelerations ``qdd`` (n,)."""


class ArrayPlant:
    """Computed-torque control and RK4 integration of array dynamics, on numpy arrays.

    Parameters
    ----------
    dynamics : ArrayDynamics
        The true robot.
    kp, kd : float or sequence of n float
        Controller gains (1/s², 1/s), > 0.
    effort_max : sequence of n float
        Symmetric effort limits (N·m, N), > 0.
    controller_dynamics : ArrayDynamics, optional
        The model the controller believes in; default ``dynamics``.
    """

    def __init__(self, dynamics: ArrayDynamics, kp: float | Sequence[float],
                 kd: float | Sequence[float], effort_max: Sequence[float], *,
                 controller_dynamics: ArrayDynamics | None = None) -> None:
        n = dynamics.n_joints
        self.dynamics = dynamics
        self.controller_dynamics = dynamics if controller_dynamics is None else controller_dynamics
        self.n_joints = n
        self.kp = np.array(_vector('kp', kp, n, minimum=0.0, allow_scalar=True))   # 1/s²
        self.kd = np.array(_vector('kd', kd, n, minimum=0.0, allow_scalar=True))   # 1/s
        self.effort_max = _vector('effort_max', effort_max, n, minimum=0.0)
        self._limit = np.array(self.effort_max)
        self._minus_limit = -self._limit

    def native(self, rows: np.ndarray) -> list[Any]:
        return list(np.array(rows, dtype=float))

    def floats(self, x: Any) -> Sequence[float]:
        return x.tolist()

    def add(self, x: Any, y: Any) -> Any:
        return np.add(x, y)

    def sub(self, x: Any, y: Any) -> Any:
        return np.subtract(x, y)

    def control(self, q: Any, qd: Any, q_des: Any, qd_des: Any, qdd_des: Any) -> Any:
        command = qdd_des + self.kd * (qd_des - qd) + self.kp * (q_des - q)   # rad/s², m/s²
        tau = self.controller_dynamics.inverse_dynamics_single(q, qd, command)
        # np.clip costs several microseconds on a few elements: two in-place bounds instead
        np.maximum(tau, self._minus_limit, out=tau)
        return np.minimum(tau, self._limit, out=tau)

    def step(self, q: Any, qd: Any, tau: Any, h: float, substeps: int
             ) -> tuple[Any, Any, Any]:
        fd = self.dynamics.forward_dynamics_single
        qdd = fd(q, qd, tau)
        a = qdd
        hh, h6 = 0.5 * h, h / 6.0
        for step in range(substeps):
            if step:
                a = fd(q, qd, tau)
            v2 = qd + hh * a
            a2 = fd(q + hh * qd, v2, tau)
            v3 = qd + hh * a2
            a3 = fd(q + hh * v2, v3, tau)
            v4 = qd + h * a3
            a4 = fd(q + h * v3, v4, tau)
            q = q + h6 * (qd + 2.0 * (v2 + v3) + v4)
            qd = qd + h6 * (a + 2.0 * (a2 + a3) + a4)
        return qdd, q, qd


def _rk4_floats(fd: Callable[..., Any], q: tuple[float, ...], v: tuple[float, ...],
                a: tuple[float, ...], tau: tuple[float, ...], h: float, substeps: int
                ) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Integrate q' = v, v' = fd(q, v, tau) over ``substeps`` RK4 steps of length h.

    ``a`` is fd(q, v, tau) at the start, reused as the first stage. Four joints, unrolled.
    """
    hh, h6 = 0.5 * h, h / 6.0
    for step in range(substeps):
        if step:
            a = fd(q, v, tau)
        v2 = (v[0] + hh * a[0], v[1] + hh * a[1], v[2] + hh * a[2], v[3] + hh * a[3])
        q2 = (q[0] + hh * v[0], q[1] + hh * v[1], q[2] + hh * v[2], q[3] + hh * v[3])
        a2 = fd(q2, v2, tau)
        v3 = (v[0] + hh * a2[0], v[1] + hh * a2[1], v[2] + hh * a2[2], v[3] + hh * a2[3])
        q3 = (q[0] + hh * v2[0], q[1] + hh * v2[1], q[2] + hh * v2[2], q[3] + hh * v2[3])
        a3 = fd(q3, v3, tau)
        v4 = (v[0] + h * a3[0], v[1] + h * a3[1], v[2] + h * a3[2], v[3] + h * a3[3])
        q4 = (q[0] + h * v3[0], q[1] + h * v3[1], q[2] + h * v3[2], q[3] + h * v3[3])
        a4 = fd(q4, v4, tau)
        q = tuple(q[i] + h6 * (v[i] + 2.0 * (v2[i] + v3[i]) + v4[i]) for i in range(4))
        v = tuple(v[i] + h6 * (a[i] + 2.0 * (a2[i] + a3[i]) + a4[i]) for i in range(4))
    return q, v
