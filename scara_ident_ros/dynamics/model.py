"""Rigid-body model of the 4-DOF SCARA: kinematics, Lagrangian dynamics and energies.

Joint coordinates ``q = (θ1, θ2, d3, θ4)`` in (rad, rad, m, rad), conventions of
``scara-model.md``: joints 1 and 2 turn about vertical axes (counter-clockwise seen from
above), joint 3 moves the quill downward, joint 4 rolls the tool about the quill with its z
axis pointing down, so the tool turns with θ1 + θ2 − θ4 about the upward vertical.

Derivation (Lagrange). Four bodies:

* body 1, link 1: mass ``m1``, centre of mass at ``lc1`` along the link, angular velocity
  θ1' about the vertical;
* body 2, link 2: mass ``m2``, centre of mass at ``lc2`` along link 2 from joint 2's axis,
  angular velocity θ1' + θ2';
* body 3, the quill: mass ``m3`` on the quill axis (distance ``l2`` from joint 2's axis),
  turns with link 2 (θ1' + θ2') and translates down with d3';
* body 4, the wrist/tool: mass ``m4`` on the quill axis, translates with d3' and turns with
  θ1' + θ2' − θ4'.

With ``c2 = cos θ2`` the kinetic energy is

    T = ½ a θ1'² + ½ b (θ1' + θ2')² + c c2 θ1' (θ1' + θ2') + ½ m34 d3'²
        + ½ izz4 [(θ1' + θ2' − θ4')² − (θ1' + θ2')²]

where the base inertial parameters are

    a    = izz1 + m1 lc1² + (m2 + m3 + m4) l1²                (kg·m²)
    b    = izz2 + izz3 + izz4 + m2 lc2² + (m3 + m4) l2²       (kg·m²)
    c    = l1 (m2 lc2 + (m3 + m4) l2)                         (kg·m²)
    m34  = m3 + m4                                            (kg)

so T = ½ q'ᵀ M(q) q' with

    M = [[a + b + 2 c c2,  b + c c2, 0,    −izz4],
         [b + c c2,        b,        0,    −izz4],
         [0,               0,        m34,   0   ],
         [−izz4,           −izz4,    0,     izz4]].

Bodies 1 and 2 move horizontally; bodies 3 and 4 are at height z = −d3 + const with z up,
so the potential energy is V = −m34 g d3 (zero at d3 = 0) and G = ∂V/∂q = (0, 0, −m34 g, 0):
gravity pulls the quill along +d3, the actuator holds it with a negative (upward) force.
Only M11 and M12 depend on q (through θ2), which gives the Christoffel matrix

    C = [[−c s2 θ2',  −c s2 (θ1' + θ2'), 0, 0],
         [ c s2 θ1',   0,                0, 0],
         [ 0,          0,                0, 0],
         [ 0,          0,                0, 0]]

and the equation of motion (eq. 6 of the paper)

    M(q) q'' + C(q, q') q' + F(q') + G(q) + T_d = τ,
    F(q') = viscous ∘ q' + coulomb ∘ tanh(q' / coulomb_eps).

Every public method takes one state (arrays of shape (4,)) or a batch (shape (N, 4)) and
answers in kind (a matrix: (4, 4) or (N, 4, 4)), q in (rad, rad, m, rad), q' and q'' per
second and per second squared, efforts in (N·m, N·m, N, N·m); the ``*_single`` methods are
the fast unbatched path for the simulator.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from scara_ident_ros.dynamics.params import N_JOINTS, ScaraParams

__all__ = ['ScaraModel']


def _as_states(*arrays: ArrayLike) -> tuple[list[np.ndarray], bool]:
    """Return the arrays as broadcast (N, 4) float arrays and whether all were single (4,)."""
    out = []
    single = True
    for array in arrays:
        arr = np.asarray(array, dtype=float)
        if arr.ndim not in (1, 2) or arr.shape[-1] != N_JOINTS:
            raise ValueError(f'joint arrays must have shape (4,) or (N, 4), got {arr.shape}')
        single = single and arr.ndim == 1
        out.append(np.atleast_2d(arr))
    return list(np.broadcast_arrays(*out)), single


class ScaraModel:
    """Kinematics and dynamics of the SCARA for one parameter set (``params``, SI)."""

    def __init__(self, params: ScaraParams) -> None:
        self.params = params
        p = params
        m34 = p.m3 + p.m4
        self._a = p.izz1 + p.m1 * p.lc1 ** 2 + (p.m2 + m34) * p.l1 ** 2   # kg·m²
        self._b = p.izz2 + p.izz3 + p.izz4 + p.m2 * p.lc2 ** 2 + m34 * p.l2 ** 2  # kg·m²
        self._c = p.l1 * (p.m2 * p.lc2 + m34 * p.l2)                      # kg·m²
        self._m34 = m34                                                    # kg
        self._zz4 = p.izz4                                                 # kg·m²
        self._weight = m34 * p.gravity                                     # N
        self._viscous = np.array(p.viscous)
        self._coulomb = np.array(p.coulomb)
        self._eps = p.coulomb_eps
        self._fv = tuple(p.viscous)
        self._fc = tuple(p.coulomb)

    # -- kinematics ---------------------------------------------------------------------------

    def forward_kinematics(self, q: np.ndarray | Sequence[float]) -> np.ndarray:
        """Pose of the tool frame in the base frame, T0^4 = A1 A2 A3 A4 (Table 1, α2 = π).

        Position ``x = l1 c1 + l2 c12``, ``y = l1 s1 + l2 s12``, ``z = −d3 − d4`` (m); the
        tool z axis points down and its x axis has yaw ψ = θ1 + θ2 − θ4 about the upward
        vertical, so the rotation is ``[[cψ, sψ, 0], [sψ, −cψ, 0], [0, 0, −1]]``.
        """
        (q,), single = _as_states(q)
        p = self.params
        t1, t12 = q[:, 0], q[:, 0] + q[:, 1]
        yaw = t12 - q[:, 3]
        cy, sy = np.cos(yaw), np.sin(yaw)
        out = np.zeros((q.shape[0], 4, 4))
        out[:, 0, 0], out[:, 0, 1] = cy, sy
        out[:, 1, 0], out[:, 1, 1] = sy, -cy
        out[:, 2, 2] = -1.0
        out[:, 0, 3] = p.l1 * np.cos(t1) + p.l2 * np.cos(t12)
        out[:, 1, 3] = p.l1 * np.sin(t1) + p.l2 * np.sin(t12)
        out[:, 2, 3] = -q[:, 2] - p.d4
        out[:, 3, 3] = 1.0
        return out[0] if single else out

    # -- dynamics terms -----------------------------------------------------------------------

    def mass_matrix(self, q: np.ndarray | Sequence[float]) -> np.ndarray:
        """Joint-space inertia matrix M(q), symmetric positive definite.

        ``M[j, j]`` is the inertia seen by actuator j when the other joints are locked;
        only the coupling of joints 1 and 2 depends on the configuration (through cos θ2).
        In kg·m² for the revolute joints, kg for joint 3, kg·m for the revolute-prismatic
        couplings (zero here).
        """
        (q,), single = _as_states(q)
        cc2 = self._c * np.cos(q[:, 1])
        out = np.zeros((q.shape[0], 4, 4))
        out[:, 0, 0] = self._a + self._b + 2.0 * cc2
        out[:, 0, 1] = out[:, 1, 0] = self._b + cc2
        out[:, 1, 1] = self._b
        out[:, 2, 2] = self._m34
        out[:, 0, 3] = out[:, 3, 0] = out[:, 1, 3] = out[:, 3, 1] = -self._zz4
        out[:, 3, 3] = self._zz4
        return out[0] if single else out

    def coriolis_matrix(self, q: np.ndarray | Sequence[float],
                        qd: np.ndarray | Sequence[float]) -> np.ndarray:
        """Coriolis/centrifugal matrix C(q, q') from the Christoffel symbols of M.

        With this choice Ṁ − 2C is skew-symmetric; C q' is the Coriolis/centrifugal effort
        (N·m·s/rad, N·s/m).
        """
        (q, qd), single = _as_states(q, qd)
        cs2 = self._c * np.sin(q[:, 1])
        out = np.zeros((q.shape[0], 4, 4))
        out[:, 0, 0] = -cs2 * qd[:, 1]
        out[:, 0, 1] = -cs2 * (qd[:, 0] + qd[:, 1])
        out[:, 1, 0] = cs2 * qd[:, 0]
        return out[0] if single else out

    def coriolis(self, q: np.ndarray | Sequence[float],
                 qd: np.ndarray | Sequence[float]) -> np.ndarray:
        """Coriolis and centrifugal efforts C(q, q') q' (module docstring's units):
        ``(−c sin θ2 (2 θ1' θ2' + θ2'²), c sin θ2 θ1'², 0, 0)``, links 1 and 2 only."""
        (q, qd), single = _as_states(q, qd)
        cs2 = self._c * np.sin(q[:, 1])
        out = np.zeros_like(q)
        out[:, 0] = -cs2 * qd[:, 1] * (2.0 * qd[:, 0] + qd[:, 1])
        out[:, 1] = cs2 * qd[:, 0] ** 2
        return out[0] if single else out

    def gravity(self, q: np.ndarray | Sequence[float]) -> np.ndarray:
        """Gravity efforts G(q) = ∂V/∂q = (0, 0, −(m3 + m4) g, 0).

        Gravity acts along −z and the quill's positive direction is down, so the static
        force joint 3 must apply is negative (upward); the revolute axes carry no gravity
        torque. Only the shape of ``q`` matters.
        """
        (q,), single = _as_states(q)
        out = np.zeros_like(q)
        out[:, 2] = -self._weight
        return out[0] if single else out

    def friction(self, qd: np.ndarray | Sequence[float]) -> np.ndarray:
        """Joint friction F(q') = viscous ∘ q' + coulomb ∘ tanh(q' / coulomb_eps), opposing
        the motion."""
        (qd,), single = _as_states(qd)
        out = self._viscous * qd + self._coulomb * np.tanh(qd / self._eps)
        return out[0] if single else out

    # -- equations of motion ------------------------------------------------------------------

    def inverse_dynamics(self, q: np.ndarray | Sequence[float],
                         qd: np.ndarray | Sequence[float],
                         qdd: np.ndarray | Sequence[float]) -> np.ndarray:
        """Joint efforts τ = M(q) q'' + C(q, q') q' + F(q') + G(q) (no disturbance)."""
        (q, qd, qdd), single = _as_states(q, qd, qdd)
        mass = self.mass_matrix(q)
        out = (np.einsum('nij,nj->ni', mass, qdd) + self.coriolis(q, qd) + self.gravity(q)
               + self.friction(qd))
        return out[0] if single else out

    def forward_dynamics(self, q: np.ndarray | Sequence[float],
                         qd: np.ndarray | Sequence[float],
                         tau: np.ndarray | Sequence[float],
                         disturbance: np.ndarray | Sequence[float] | None = None
                         ) -> np.ndarray:
        """Joint accelerations q'' = M⁻¹ (τ − T_d − C q' − F − G), by a linear solve.

        Parameters
        ----------
        q, qd : array_like of shape (4,) or (N, 4)
            Joint positions and velocities (SI).
        tau : array_like of shape (4,) or (N, 4)
            Applied efforts (N·m, N·m, N, N·m).
        disturbance : array_like of shape (4,) or (N, 4), optional
            Disturbance efforts T_d of eq. 6, on the left-hand side like friction.

        Returns
        -------
        ndarray of shape (4,) or (N, 4)
            Accelerations (rad/s², rad/s², m/s², rad/s²).
        """
        extra = [] if disturbance is None else [disturbance]
        arrays, single = _as_states(q, qd, tau, *extra)
        q, qd, tau = arrays[:3]
        rhs = tau - self.coriolis(q, qd) - self.gravity(q) - self.friction(qd)
        if extra:
            rhs = rhs - arrays[3]
        out = np.linalg.solve(self.mass_matrix(q), rhs[..., None])[..., 0]
        return out[0] if single else out

    # -- energies -----------------------------------------------------------------------------

    def kinetic_energy(self, q: np.ndarray | Sequence[float],
                       qd: np.ndarray | Sequence[float]) -> float | np.ndarray:
        """Kinetic energy ½ q'ᵀ M(q) q' of the four bodies (J): a float, or (N,)."""
        (q, qd), single = _as_states(q, qd)
        out = 0.5 * np.einsum('ni,nij,nj->n', qd, self.mass_matrix(q), qd)
        return float(out[0]) if single else out

    def potential_energy(self, q: np.ndarray | Sequence[float]) -> float | np.ndarray:
        """Gravitational potential energy V = −(m3 + m4) g d3 (J), zero at d3 = 0: a float,
        or (N,)."""
        (q,), single = _as_states(q)
        out = -self._weight * q[:, 2]
        return float(out[0]) if single else out

    # -- fast single-state path ---------------------------------------------------------------

    def inverse_dynamics_single(self, q: Sequence[float], qd: Sequence[float],
                                qdd: Sequence[float]) -> tuple[float, float, float, float]:
        """Same as :meth:`inverse_dynamics` for one state, in plain Python floats.

        For simulators and controllers running at kHz rates, where array overheads would
        dominate.
        """
        th2 = q[1]
        v1, v2, v3, v4 = qd
        a1, a2, a3, a4 = qdd
        b, zz4 = self._b, self._zz4
        cc2 = self._c * math.cos(th2)
        cs2 = self._c * math.sin(th2)
        eps = self._eps
        fv, fc = self._fv, self._fc
        m12 = b + cc2
        return ((self._a + b + 2.0 * cc2) * a1 + m12 * a2 - zz4 * a4
                - cs2 * v2 * (2.0 * v1 + v2) + fv[0] * v1 + fc[0] * math.tanh(v1 / eps),
                m12 * a1 + b * a2 - zz4 * a4 + cs2 * v1 * v1
                + fv[1] * v2 + fc[1] * math.tanh(v2 / eps),
                self._m34 * a3 - self._weight + fv[2] * v3 + fc[2] * math.tanh(v3 / eps),
                zz4 * (a4 - a1 - a2) + fv[3] * v4 + fc[3] * math.tanh(v4 / eps))

    def forward_dynamics_single(self, q: Sequence[float], qd: Sequence[float],
                                tau: Sequence[float]) -> tuple[float, float, float, float]:
        """Same as :meth:`forward_dynamics` for one state, in plain Python floats.

        Uses the structure of M: joint 4's row gives q4'' = q1'' + q2'' + r4 / izz4, which
        leaves a 2×2 system for joints 1 and 2 solved in closed form, and joint 3 is
        decoupled. ``tau`` is the net applied effort (subtract any disturbance T_d first).
        """
        th2 = q[1]
        v1, v2, v3, v4 = qd
        b, zz4 = self._b, self._zz4
        cc2 = self._c * math.cos(th2)
        cs2 = self._c * math.sin(th2)
        eps = self._eps
        fv, fc = self._fv, self._fc
        r4 = tau[3] - fv[3] * v4 - fc[3] * math.tanh(v4 / eps)
        r1 = (tau[0] + cs2 * v2 * (2.0 * v1 + v2) - fv[0] * v1
              - fc[0] * math.tanh(v1 / eps) + r4)
        r2 = tau[1] - cs2 * v1 * v1 - fv[1] * v2 - fc[1] * math.tanh(v2 / eps) + r4
        m11 = self._a + b + 2.0 * cc2 - zz4
        m12 = b + cc2 - zz4
        m22 = b - zz4
        det = m11 * m22 - m12 * m12
        a1 = (m22 * r1 - m12 * r2) / det
        a2 = (m11 * r2 - m12 * r1) / det
        a3 = (tau[2] + self._weight - fv[2] * v3 - fc[2] * math.tanh(v3 / eps)) / self._m34
        return a1, a2, a3, a1 + a2 + r4 / zz4
