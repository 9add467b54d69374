"""Fixed-rate simulation of a robot tracking an excitation under computed-torque control.

The robot is the SCARA (:class:`~scara_ident_ros.dynamics.params.ScaraParams`) or a URDF's
(:class:`~scara_ident_ros.sim.pinocchio_robot.PinocchioRobot`); the robot-specific maths of
one sample is its plant (:mod:`scara_ident_ros.sim.plant`), the rest here is shared.

Each sample k at time t_k = k·dt (plus, with ``jitter``, a seeded offset e_k: the stamps of a
real-time loop, see :mod:`scara_ident_ros.sim.jitter`):

1. the sensors read q and q' (true state plus optional Gaussian noise);
2. the controller computes τ_k from the readings and the desired q, q', q'' at t_k, clipped
   to the effort limits; τ_k and the disturbance T_d(t_k) are held over [t_k, t_{k+1})
   (zero-order hold, like a digital drive);
3. the sample reports the readings, the true acceleration
   q''_k = M⁻¹ (τ_k − T_d − τ_ext − C q' − F − G) at the true state (M with the rotor
   inertias of a URDF robot), and τ_k plus optional noise;
4. the true state is integrated to t_{k+1} by ``substeps`` classical RK4 steps.

τ_ext is an external effort (a contact, :meth:`Simulator.apply_external`): a load like T_d,
while the reported effort stays the actuator's τ_k, so a model of the free robot sees
measured − predicted ≈ τ_ext. With jitter each step lasts t_{k+1} − t_k, so every sample is
the state at its own stamp. The SCARA's per-sample work runs on Python floats
(``ScaraModel.*_single``), a URDF robot's on numpy arrays, so that a 1 kHz node keeps up.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import (N_JOINTS, ParamError, ScaraParams, _check_keys,
                                             _integer, _scalar, _vector)
from scara_ident_ros.sim.controller import ComputedTorqueController
from scara_ident_ros.sim.jitter import MAX_JITTER_FRACTION, StampJitter
from scara_ident_ros.sim.plant import ArrayPlant, Plant, ScaraPlant
from scara_ident_ros.sim.sequence import SequenceTrajectory
from scara_ident_ros.sim.trajectory import FourierTrajectory
from scara_ident_ros.sim.trajectory_follower import TrajectoryFollower

if TYPE_CHECKING:
    from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot

__all__ = ['DISTURBANCES', 'SimConfig', 'SimSample', 'SimRecord', 'Simulator']

#: Kinds of disturbance T_d (eq. 6): a sinusoid per joint with a random phase, or
#: Gauss-Markov (first-order low-pass) random efforts.
DISTURBANCES = ('sinusoid', 'random')

_CHUNK = 1024          # desired-trajectory samples evaluated per vectorised batch


@dataclass(frozen=True)
class SimConfig:
    """Settings of a simulation run, validated on construction.

    Attributes
    ----------
    dt : float
        Sample period (s), a whole number of nanoseconds; ``substeps`` RK4 steps per sample.
    kp, kd : tuple of n_joints float
        Controller gains (1/s², 1/s); a scalar applies to every joint.
    position_noise, velocity_noise, effort_noise : tuple of n_joints float
        Standard deviations of the Gaussian noise on the reported q (rad, m), q' (rad/s,
        m/s) and efforts (N·m, N); the controller sees the noisy q and q'.
    disturbance : float
        Size of T_d as a fraction in [0, 1] of each effort limit (sinusoid amplitude or
        random standard deviation); 0: off. ``disturbance_frequency_hz``: its frequency or
        bandwidth (Hz).
    model_mismatch : float
        Relative error in [0, 1) of the controller's model (``ScaraParams.perturbed``).
    jitter : float
        Standard deviation (s) of each stamp around k·dt, in [0, dt / 2]
        (:class:`StampJitter`).
    seed : int
        Seed of the noise, disturbance, mismatch and jitter draws.
    n_joints : int
        Length of the per-joint settings, the robot's joints.
    """

    dt: float = 1e-3                                             # s
    substeps: int = 4
    kp: tuple[float, ...] | float = 400.0                        # 1/s², ωn = 20 rad/s
    kd: tuple[float, ...] | float = 40.0                         # 1/s, critically damped
    position_noise: tuple[float, ...] | float = 0.0              # rad or m, per joint
    velocity_noise: tuple[float, ...] | float = 0.0              # rad/s or m/s, per joint
    effort_noise: tuple[float, ...] | float = 0.0                # N·m or N, per joint
    disturbance: float = 0.0                                     # fraction of effort_max
    disturbance_kind: str = 'sinusoid'
    disturbance_frequency_hz: float = 0.5                        # Hz
    model_mismatch: float = 0.0
    jitter: float = 0.0                                          # s
    seed: int = 0
    n_joints: int = N_JOINTS

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        n = _integer('n_joints', self.n_joints, minimum=1)
        set_(self, 'n_joints', n)
        set_(self, 'dt', _scalar('dt', self.dt, minimum=0.0))
        if abs(self.dt * 1e9 - round(self.dt * 1e9)) > 1e-3:
            raise ParamError(f'dt must be a whole number of nanoseconds, got {self.dt!r}')
        set_(self, 'substeps', _integer('substeps', self.substeps, minimum=1))
        for name in ('kp', 'kd'):
            set_(self, name, _vector(name, getattr(self, name), n, minimum=0.0,
                                     allow_scalar=True))
        for name in ('position_noise', 'velocity_noise', 'effort_noise'):
            set_(self, name, _vector(name, getattr(self, name), n, minimum=0.0, strict=False,
                                     allow_scalar=True))
        set_(self, 'disturbance',
             _scalar('disturbance', self.disturbance, minimum=0.0, strict=False))
        if self.disturbance > 1.0:
            raise ParamError(f'disturbance must be <= 1 (a fraction of effort_max), '
                             f'got {self.disturbance!r}')
        if self.disturbance_kind not in DISTURBANCES:
            raise ParamError(f'disturbance_kind must be one of {", ".join(DISTURBANCES)}, '
                             f'got {self.disturbance_kind!r}')
        set_(self, 'disturbance_frequency_hz',
             _scalar('disturbance_frequency_hz', self.disturbance_frequency_hz, minimum=0.0))
        set_(self, 'model_mismatch',
             _scalar('model_mismatch', self.model_mismatch, minimum=0.0, strict=False))
        if self.model_mismatch >= 1.0:
            raise ParamError(f'model_mismatch must be < 1, got {self.model_mismatch!r}')
        set_(self, 'jitter', _scalar('jitter', self.jitter, minimum=0.0, strict=False))
        if self.jitter > MAX_JITTER_FRACTION * self.dt:
            raise ParamError(f'jitter must be <= {MAX_JITTER_FRACTION:g} dt = '
                             f'{MAX_JITTER_FRACTION * self.dt:g} s, got {self.jitter!r}')
        set_(self, 'seed', _integer('seed', self.seed, minimum=0))

    @property
    def dt_ns(self) -> int:
        """Sample period in integer nanoseconds."""
        return round(self.dt * 1e9)

    @classmethod
    def from_dict(cls, mapping: Mapping[str, Any]) -> SimConfig:
        """Build a configuration from a mapping; missing names take the defaults.

        Raises
        ------
        ParamError
            For a non-mapping, unknown names or invalid values.
        """
        return cls(**_check_keys(cls, mapping, cls.__name__))

    def to_dict(self) -> dict[str, Any]:
        """Return the settings as plain Python values (lists for the per-joint ones)."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v)
                for f in fields(self)}


@dataclass(frozen=True)
class SimSample:
    """One sample of the simulated robot.

    Attributes
    ----------
    stamp_ns : int
        k · dt plus its jitter (ns).
    q, qd : ndarray of shape (n,)
        Measured positions (rad or m) and velocities (rad/s, m/s), noise included.
    qdd : ndarray of shape (n,)
        True accelerations (rad/s², m/s²).
    effort : ndarray of shape (n,)
        Applied (clipped) efforts over the step, noise included (N·m or N).
    """

    stamp_ns: int
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    effort: np.ndarray


@dataclass(frozen=True)
class SimRecord:
    """n consecutive samples as arrays.

    Attributes
    ----------
    stamp_ns : ndarray of shape (n,), int64
        Sample times (ns).
    q, qd, qdd, effort : ndarray of shape (n, n_joints)
        As in :class:`SimSample`.
    """

    stamp_ns: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    effort: np.ndarray

    def __len__(self) -> int:
        return int(self.stamp_ns.shape[0])


class Simulator:
    """A robot (plant), its computed-torque controller, sensors and disturbance.

    Parameters
    ----------
    params : ScaraParams or PinocchioRobot
        The true robot: the SCARA's parameters, or a URDF robot with its friction.
    trajectory : FourierTrajectory, SequenceTrajectory or TrajectoryFollower
        Desired motion for the same robot; the state starts on it at t = 0.
    config : SimConfig, optional
        Settings; by default ``SimConfig`` with the robot's number of joints.

    Raises
    ------
    ParamError
        If the configuration's ``n_joints`` is not the robot's.
    """

    def __init__(self, params: ScaraParams | PinocchioRobot,
                 trajectory: FourierTrajectory | SequenceTrajectory | TrajectoryFollower,
                 config: SimConfig | None = None) -> None:
        self.params = params
        self.trajectory = trajectory
        n = len(params.effort_max)
        self.config = SimConfig(n_joints=n) if config is None else config
        cfg = self.config
        if cfg.n_joints != n:
            raise ParamError(f'the simulation settings are for {cfg.n_joints} joints, the '
                             f'robot has {n}: give SimConfig(n_joints={n}, ...)')
        noise_seed, disturbance_seed, mismatch_seed, jitter_seed = (
            np.random.SeedSequence(cfg.seed).spawn(4))
        self._noise_seed = noise_seed
        self._disturbance_seed = disturbance_seed
        mismatch = int(mismatch_seed.generate_state(1)[0])
        self.model: Any
        self.controller: Any
        self.plant: Plant
        if isinstance(params, ScaraParams):
            self.model = ScaraModel(params)
            controller_params = params
            if cfg.model_mismatch > 0.0:
                controller_params = params.perturbed(cfg.model_mismatch, seed=mismatch)
            self.controller = ComputedTorqueController(
                ScaraModel(controller_params), cfg.kp, cfg.kd, effort_max=params.effort_max)
            self.plant = ScaraPlant(self.model, self.controller)
        else:
            self.model = params
            believed = (params.perturbed(cfg.model_mismatch, seed=mismatch)
                        if cfg.model_mismatch > 0.0 else params)
            self.controller = self.plant = ArrayPlant(
                params, cfg.kp, cfg.kd, params.effort_max, controller_dynamics=believed)
        self._n = n
        self._dt_ns = cfg.dt_ns
        self._h = cfg.dt / cfg.substeps
        self._jitter = StampJitter(cfg.dt_ns, cfg.jitter,
                                   seed=int(jitter_seed.generate_state(1)[0]))
        self._noise_std = np.array([cfg.position_noise, cfg.velocity_noise,
                                    cfg.effort_noise], dtype=float).ravel()   # (3 n,)
        self._noisy = bool(self._noise_std.any())
        self._kind = cfg.disturbance_kind if cfg.disturbance > 0.0 else 'none'
        self._amplitude = tuple(cfg.disturbance * e for e in params.effort_max)  # N·m, N
        self.reset()

    # -- state --------------------------------------------------------------------------------

    def reset(self) -> None:
        """Go back to t = 0 on the trajectory and restart the random streams."""
        cfg = self.config
        n = self._n
        self._k = 0
        self._stamp_ns = self._jitter.stamp_ns(0)
        q, qd, _ = self.trajectory.evaluate(0.0)
        self._q, self._qd = self.plant.native(np.stack([q, qd]))
        self._noise_rng = np.random.default_rng(self._noise_seed)
        rng = np.random.default_rng(self._disturbance_seed)
        self._phase = tuple(rng.uniform(0.0, 2.0 * math.pi, n).tolist())
        self._dist_rng = rng
        self._dist = (tuple((np.array(self._amplitude) * rng.standard_normal(n)).tolist())
                      if self._kind == 'random' else (0.0,) * n)
        self._alpha = math.exp(-2.0 * math.pi * cfg.disturbance_frequency_hz * cfg.dt)
        self._chunk_start = 0
        self._desired: list[tuple[Any, Any, Any]] = []
        self._external: Any = None  # τ_ext in the plant's vectors, None: no contact

    @property
    def stamp_ns(self) -> int:
        """Stamp of the next sample (ns)."""
        return self._stamp_ns

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """True (noise-free) positions and velocities of the next sample, two (n,) arrays."""
        return np.array(self._q), np.array(self._qd)

    @property
    def external(self) -> np.ndarray:
        """External effort τ_ext acting from the next sample on, shape (n,) (N·m, N)."""
        return (np.zeros(self._n) if self._external is None
                else np.array(self.plant.floats(self._external), dtype=float))

    def apply_external(self, effort: Sequence[float] | np.ndarray | None) -> None:
        """Apply the external effort ``effort`` (n,) (N·m, N) from the next sample on,
        until the next call; None or all zeros: none.

        Raises
        ------
        ValueError
            If ``effort`` has not n finite values.
        """
        if effort is None:
            self._external = None
            return
        values = np.asarray(effort, dtype=float)
        if values.shape != (self._n,) or not np.all(np.isfinite(values)):
            raise ValueError(f'external effort must be {self._n} finite values, got {effort!r}')
        self._external = self.plant.native(values[None, :])[0] if values.any() else None

    def disturbance(self) -> np.ndarray:
        """Disturbance T_d acting over the next step, shape (n,) (N·m, N)."""
        return np.array(self._disturbance_now())

    # -- stepping -----------------------------------------------------------------------------

    def step(self) -> SimSample:
        """Produce the sample at the current time and advance the state by dt."""
        stamp, q, qd, qdd, effort = self.advance()
        return SimSample(stamp, np.array(q), np.array(qd), np.array(qdd), np.array(effort))

    def simulate(self, n: int) -> SimRecord:
        """Run ``n`` samples: the same numbers as ``n`` calls of :meth:`step`."""
        n = _integer('n', n, minimum=0)
        rows = [self.advance() for _ in range(n)]
        stamps = np.array([row[0] for row in rows], dtype=np.int64)
        columns = [np.array([row[i] for row in rows], dtype=float).reshape(n, self._n)
                   for i in range(1, 5)]
        return SimRecord(stamps, *columns)

    def advance(self) -> tuple[int, Sequence[float], Sequence[float], Sequence[float],
                               Sequence[float]]:
        """One sample, ``(stamp_ns, q, qd, qdd, effort)`` as in :class:`SimSample` but in
        plain Python floats: the 1 kHz node copies them into its message without arrays."""
        k = self._k
        n = self._n
        plant = self.plant
        q, qd = self._q, self._qd
        q_des, qd_des, qdd_des = self._desired_at(k)
        if self._noisy:
            z = plant.native((self._noise_rng.standard_normal(3 * n)
                              * self._noise_std).reshape(3, n))
            q_meas, qd_meas = plant.add(q, z[0]), plant.add(qd, z[1])
        else:
            z = None
            q_meas, qd_meas = q, qd
        tau = plant.control(q_meas, qd_meas, q_des, qd_des, qdd_des)
        net = tau if self._kind == 'none' else plant.sub(tau, self._disturbance_now())
        if self._external is not None:
            net = plant.sub(net, self._external)
        stamp = self._stamp_ns
        h = self._h
        if self.config.jitter:
            self._stamp_ns = self._jitter.stamp_ns(k + 1)
            h = (self._stamp_ns - stamp) * 1e-9 / self.config.substeps  # s
        else:
            self._stamp_ns = stamp + self._dt_ns
        qdd, self._q, self._qd = plant.step(q, qd, net, h, self.config.substeps)
        if self._kind == 'random':
            alpha = self._alpha
            gain = math.sqrt(1.0 - alpha * alpha)
            xi = self._dist_rng.standard_normal(n).tolist()
            self._dist = tuple(alpha * d_i + gain * a_i * x_i for d_i, a_i, x_i
                               in zip(self._dist, self._amplitude, xi))
        effort = tau if z is None else plant.add(tau, z[2])
        self._k = k + 1
        floats = plant.floats
        return stamp, floats(q_meas), floats(qd_meas), floats(qdd), floats(effort)

    # -- internals ----------------------------------------------------------------------------

    def _desired_at(self, k: int) -> tuple[Any, Any, Any]:
        """Desired q, q', q'' at sample k's stamp, from a vectorised batch evaluated ahead."""
        index = k - self._chunk_start
        if not 0 <= index < len(self._desired):
            self._chunk_start = k
            batch = getattr(self.trajectory, 'batch_samples', _CHUNK)
            times = self._jitter.stamps_ns(k, batch) * 1e-9
            q, qd, qdd = self.trajectory.evaluate(times)
            native = self.plant.native
            self._desired = list(zip(native(q), native(qd), native(qdd)))
            index = 0
        return self._desired[index]

    def _disturbance_now(self) -> tuple[float, ...]:
        if self._kind == 'sinusoid':
            w_t = (2.0 * math.pi * self.config.disturbance_frequency_hz
                   * self._stamp_ns * 1e-9)                                    # rad
            return tuple(a * math.sin(w_t + p) for a, p in zip(self._amplitude, self._phase))
        return self._dist

