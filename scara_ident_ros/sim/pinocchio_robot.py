"""Any robot arm from its URDF: rigid-body dynamics by Pinocchio, rotor inertia, friction, limits.

The URDF gives the links' masses and inertias, the joints' axes and their limits
(position range, velocity, effort). The simulated drive adds what a URDF usually leaves
out, per joint:

- a rotor inertia (``armature``, kg·m² or kg), the motor's inertia seen through its gear,
  added to the diagonal of the mass matrix by Pinocchio's ABA, CRBA and RNEA alike; by
  default the URDF's own (Pinocchio's ``model.armature``) where it is positive, else
  :data:`ARMATURE_PER_EFFORT` × the effort limit (a 150 N·m joint: 0.15 kg·m², the order of
  a 100:1 harmonic drive's reflected rotor);
- friction with a Stribeck stick-slip characteristic (:class:`JointFriction`), by default
  in proportion to the effort limit (:data:`FRICTION_DEFAULTS`: viscous 2 % of it per
  rad/s, Coulomb 3 %, breakaway 4 %), as identified on harmonic-drive arms; the URDF's
  ``<dynamics damping friction>`` are not used;
- an acceleration limit, which URDF has no field for: by default (:func:`default_acceleration_max`)
  the smaller of half the effort limit over the largest inertia the joint sees across its
  range and 10 s⁻¹ × the velocity limit.

Joints of the URDF that are not simulated (a gripper's fingers) are locked with
``pin.buildReducedModel``, at the middle of their range: their links become part of the
link they hang from.

The dynamics, with τ the effort the drive applies (N·m or N):

    τ = M(q) q'' + C(q, q') q' + G(q) + A q'' + F(q')      (A = diag(armature))

:meth:`PinocchioRobot.inverse_dynamics` is ``pin.rnea`` (which includes A q'') plus F;
:meth:`PinocchioRobot.forward_dynamics` is ``pin.aba`` on τ − F.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from scara_ident_ros.dynamics.params import ParamError, _scalar, _vector
from scara_ident_ros.dynamics.urdf_limits import UrdfLimits, parse_urdf
from scara_ident_ros.sim.joint_friction import JointFriction

__all__ = ['PinocchioRobot', 'ARMATURE_PER_EFFORT', 'FRICTION_DEFAULTS',
           'ACCELERATION_EFFORT_FRACTION', 'ACCELERATION_PER_VELOCITY',
           'default_acceleration_max']

#: Default rotor inertia per unit of effort limit (kg·m² per N·m, i.e. s²/rad).
ARMATURE_PER_EFFORT = 1e-3
#: Default friction, as fractions of each joint's effort limit (viscous: per rad/s or m/s)
#: and velocities (rad/s or m/s); keywords of :meth:`JointFriction.scaled`.
FRICTION_DEFAULTS: dict[str, float] = {
    'viscous': 0.02, 'coulomb': 0.03, 'static': 0.04,
    'stribeck_velocity': 0.1, 'stick_velocity': 0.05,
}
#: Default acceleration limit: this fraction of the effort limit over the largest inertia ...
ACCELERATION_EFFORT_FRACTION = 0.5
#: ... and at most this many times the velocity limit (1/s).
ACCELERATION_PER_VELOCITY = 10.0
_INERTIA_SAMPLES = 64   # configurations over which the largest inertia is taken


class PinocchioRobot:
    """A URDF robot's dynamics with rotor inertia and friction, and its joint limits.

    Build it with :meth:`from_urdf`; the constructor takes a ready Pinocchio model.

    Parameters
    ----------
    model : pinocchio.Model
        The model of the simulated joints only, each revolute or prismatic (nq = nv = n);
        its ``armature`` is the rotor inertia.
    limits : UrdfLimits
        The URDF's limits of those joints, in the model's order.
    friction : JointFriction
        Friction of the n joints.
    acceleration_max : sequence of n float, optional
        Acceleration limits (rad/s² or m/s²); default :func:`default_acceleration_max`.
    source : str, optional
        Where the URDF came from, for messages.

    Attributes
    ----------
    data : pinocchio.Data
        The model's workspace.
    armature : tuple of n float
        Rotor inertias (kg·m² or kg).
    position_min, position_max, velocity_max, acceleration_max, effort_max : tuple of float
        Limits (SI), as :class:`~scara_ident_ros.dynamics.params.ScaraParams` has them.
    """

    def __init__(self, model: Any, limits: UrdfLimits, friction: JointFriction, *,
                 acceleration_max: Sequence[float] | None = None,
                 source: str = 'robot_description') -> None:
        names = tuple(model.names[1:])
        if model.nq != model.nv or model.nv != len(names):
            raise ParamError(f'{source}: only revolute and prismatic joints can be simulated; '
                             f'the model has nq = {model.nq}, nv = {model.nv} for '
                             f'{len(names)} joints (a continuous or multi-DOF joint?)')
        if limits.names != names:
            raise ParamError(f'{source}: limits for {list(limits.names)}, model joints '
                             f'{list(names)}')
        n = len(names)
        if friction.n_joints != n:
            raise ParamError(f'{source}: friction for {friction.n_joints} joints, the robot '
                             f'has {n}')
        self.model = model
        self.data = model.createData()
        self.source = source
        self.joint_names = names
        self.n_joints = n
        self.friction = friction
        self.armature = tuple(float(a) for a in model.armature)
        self.position_min = tuple(limits.position_min.tolist())
        self.position_max = tuple(limits.position_max.tolist())
        self.velocity_max = tuple(limits.velocity_max.tolist())
        self.effort_max = tuple(limits.effort_max.tolist())
        self._limits = limits
        if acceleration_max is None:
            acceleration_max = default_acceleration_max(self)
        self.acceleration_max = _vector('acceleration_max', acceleration_max, n, minimum=0.0)

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def from_urdf(cls, urdf: str | Path, *, joints: Sequence[str] = (),
                  armature: Sequence[float] | None = None,
                  friction: JointFriction | None = None,
                  acceleration_max: Sequence[float] | None = None) -> PinocchioRobot:
        """Build the robot from a URDF file or document.

        Parameters
        ----------
        urdf : str or Path
            A path to a URDF file, or the URDF document itself (a string that starts with
            ``<``, e.g. a ``robot_description``).
        joints : sequence of str, optional
            The joints to simulate, in the order they are published; empty: every
            revolute and prismatic joint with limits. The URDF's other joints are locked
            at the middle of their range (0 for one without a range).
        armature : sequence of n float, optional
            Rotor inertias (kg·m² or kg), >= 0; default as the module docstring says.
        friction : JointFriction, optional
            Default: :data:`FRICTION_DEFAULTS` scaled by the effort limits.
        acceleration_max : sequence of n float, optional
            Default: :func:`default_acceleration_max`.

        Raises
        ------
        UrdfError
            For a document that is not a URDF, or a simulated joint without limits.
        ParamError
            For an unknown joint name, a continuous joint, or invalid values.
        """
        text, source = _read(urdf)
        limits_all = parse_urdf(text, source=source)
        full = pin.buildModelFromXML(text)
        known = list(full.names[1:])
        wanted = tuple(joints) or limits_all.names
        unknown = [name for name in wanted if name not in known]
        if unknown or len(set(wanted)) != len(wanted):
            raise ParamError(f'{source}: joints {list(wanted)} must be distinct joints of the '
                             f'URDF; it has {known}')
        in_urdf_order = tuple(name for name in known if name in wanted)
        if in_urdf_order != wanted:   # Pinocchio keeps the URDF's order of the joints
            raise ParamError(f'{source}: list the joints in the URDF order, '
                             f'{list(in_urdf_order)}, not {list(wanted)}')
        limits = limits_all.select(wanted)
        locked = [name for name in known if name not in wanted]
        model = full
        if locked:
            q_lock = pin.neutral(full)
            for name in locked:
                joint = full.joints[full.getJointId(name)]
                if joint.nq == 1 and name in limits_all.names:
                    i = limits_all.names.index(name)
                    q_lock[joint.idx_q] = 0.5 * (limits_all.position_min[i]
                                                 + limits_all.position_max[i])
            model = pin.buildReducedModel(full, [full.getJointId(n) for n in locked], q_lock)
        n = len(wanted)
        effort = limits.effort_max
        if armature is None:
            urdf_armature = np.array(model.armature, dtype=float)
            rotor = np.where(urdf_armature > 0.0, urdf_armature, ARMATURE_PER_EFFORT * effort)
        else:
            rotor = np.array(_vector('armature', armature, n, minimum=0.0, strict=False))
        model.armature = rotor
        if friction is None:
            friction = JointFriction.scaled(effort, **FRICTION_DEFAULTS)
        return cls(model, limits, friction, acceleration_max=acceleration_max, source=source)

    # -- limits, as ScaraParams has them ------------------------------------------------------

    def array(self, name: str) -> np.ndarray:
        """The per-joint limit ``name`` (e.g. ``'effort_max'``) as a new array (n,)."""
        if name not in ('position_min', 'position_max', 'velocity_max', 'acceleration_max',
                        'effort_max', 'armature'):
            raise ParamError(f'{name} is not a per-joint field of a URDF robot')
        return np.array(getattr(self, name), dtype=float)

    @property
    def position_centre(self) -> np.ndarray:
        """Middle of each joint's range, shape (n,) (rad or m)."""
        return 0.5 * (self.array('position_min') + self.array('position_max'))

    def __repr__(self) -> str:
        return f'PinocchioRobot({self.source!r}, joints={list(self.joint_names)})'

    # -- dynamics -----------------------------------------------------------------------------

    def inverse_dynamics_single(self, q: np.ndarray, qd: np.ndarray,
                                qdd: np.ndarray) -> np.ndarray:
        """Efforts (n,) (N·m or N) for one state: RNEA with rotor inertia, plus friction."""
        return pin.rnea(self.model, self.data, q, qd, qdd) + self.friction(qd)

    def forward_dynamics_single(self, q: np.ndarray, qd: np.ndarray,
                                tau: np.ndarray) -> np.ndarray:
        """Accelerations (n,) (rad/s² or m/s²) under the applied efforts ``tau`` (n,)."""
        return pin.aba(self.model, self.data, q, qd, tau - self.friction(qd)).copy()

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Efforts for one state (n,) or a batch (N, n) of q, q', q'' (SI), as they are."""
        q, qd, qdd = (np.asarray(x, dtype=float) for x in (q, qd, qdd))
        if q.ndim == 1:
            return self.inverse_dynamics_single(q, qd, qdd)
        model, data = self.model, self.data
        out = np.array([pin.rnea(model, data, *row) for row in zip(q, qd, qdd)])
        return out.reshape(q.shape) + self.friction(qd)

    def forward_dynamics(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Accelerations for one state (n,) or a batch (N, n) of q, q', τ (SI)."""
        q, qd, tau = (np.asarray(x, dtype=float) for x in (q, qd, tau))
        if q.ndim == 1:
            return self.forward_dynamics_single(q, qd, tau)
        net = tau - self.friction(qd)
        model, data = self.model, self.data
        return np.array([pin.aba(model, data, *row) for row in zip(q, qd, net)]
                        ).reshape(q.shape)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M(q) + diag(armature), shape (n, n) (kg·m², kg)."""
        m = pin.crba(self.model, self.data, np.asarray(q, dtype=float))
        return np.triu(m) + np.triu(m, 1).T

    def replaced(self, *, friction: JointFriction | None = None,
                 acceleration_max: Sequence[float] | None = None) -> PinocchioRobot:
        """A copy with another friction and/or other acceleration limits (None: the same)."""
        return PinocchioRobot(
            self.model, self._limits, self.friction if friction is None else friction,
            acceleration_max=(self.acceleration_max if acceleration_max is None
                              else acceleration_max), source=self.source)

    def max_stable_step(self) -> float:
        """Longest RK4 step (s) the friction's sticking band allows (see JointFriction)."""
        return self.friction.max_stable_step(self.armature)

    def perturbed(self, relative: float, *, seed: int) -> PinocchioRobot:
        """A copy with link masses and inertias, rotor inertias and friction levels scaled.

        Each by ``1 + relative * u``, u uniform in [-1, 1] (seeded; the static level by the
        Coulomb level's factor); geometry, centres of mass and limits unchanged. A
        controller's model mismatch.
        """
        relative = _scalar('relative', relative, minimum=0.0, strict=False)
        if relative >= 1.0:
            raise ParamError(f'relative must be < 1, got {relative!r}')
        rng = np.random.default_rng(seed)
        model = self.model.copy()
        for i in range(1, model.njoints):
            inertia = model.inertias[i]
            factor = 1.0 + relative * rng.uniform(-1.0, 1.0)
            model.inertias[i] = pin.Inertia(inertia.mass * factor, inertia.lever,
                                            inertia.inertia * factor)
        n = self.n_joints
        model.armature = np.array(self.armature) * (1.0 + relative * rng.uniform(-1, 1, n))
        f = self.friction
        scale = 1.0 + relative * rng.uniform(-1.0, 1.0, (2, n))
        friction = JointFriction(tuple((np.array(f.viscous) * scale[0]).tolist()),
                                 tuple((np.array(f.coulomb) * scale[1]).tolist()),
                                 tuple((np.array(f.static) * scale[1]).tolist()),
                                 f.stribeck_velocity, f.stick_velocity)
        return PinocchioRobot(model, self._limits, friction,
                              acceleration_max=self.acceleration_max, source=self.source)


def default_acceleration_max(robot: PinocchioRobot) -> tuple[float, ...]:
    """Acceleration limits for a URDF, which has none (rad/s² or m/s²), shape (n,).

    Per joint, the smaller of :data:`ACCELERATION_EFFORT_FRACTION` × effort_max over the
    largest diagonal inertia M_ii + armature over :data:`_INERTIA_SAMPLES` seeded
    configurations within the limits (the acceleration half the effort can give the joint
    in its heaviest pose) and :data:`ACCELERATION_PER_VELOCITY` × velocity_max (reaching
    full speed in a tenth of a second, as industrial arms do).
    """
    rng = np.random.default_rng(0)
    low, high = robot.array('position_min'), robot.array('position_max')
    q = low + (high - low) * rng.random((_INERTIA_SAMPLES, robot.n_joints))
    inertia = np.max([np.diag(robot.mass_matrix(row)) for row in q], axis=0)
    by_effort = ACCELERATION_EFFORT_FRACTION * robot.array('effort_max') / inertia
    by_velocity = ACCELERATION_PER_VELOCITY * robot.array('velocity_max')
    return tuple(float(x) for x in np.minimum(by_effort, by_velocity))


def _read(urdf: str | Path) -> tuple[str, str]:
    """The URDF text and where it came from."""
    if isinstance(urdf, str) and urdf.lstrip().startswith('<'):
        return urdf, 'robot_description'
    path = Path(urdf)
    try:
        return path.read_text(encoding='utf-8'), str(path)
    except (OSError, UnicodeDecodeError) as exc:
        raise ParamError(f'{path}: cannot read the URDF: {exc}') from None

