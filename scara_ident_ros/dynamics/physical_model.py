"""A physical inverse-dynamics model of any URDF robot: base parameters and joint friction.

The rigid-body efforts of a robot are linear in 10 inertial parameters per body
(m, m·c_x, m·c_y, m·c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz, about the body's joint frame:
Pinocchio's ``computeJointTorqueRegressor``) and in a rotor inertia per joint (armature:
a column q''_j in row j). Added per joint j, viscous friction f_v,j q'_j and Coulomb friction
f_c,j s(q'_j), with s the sign or the smooth tanh(q'_j / ε) (``coulomb``). So

    τ = Y(q, q', q'') θ,    Y = [W_ind | diag(q') | diag(s(q'))],    θ = [θ_b, f_v, f_c],

and with a Stribeck velocity v_s > 0 (``stribeck_velocity``) a third friction column per
joint, diag(exp(−(q'/v_s)²) s(q')), whose coefficient f_s,j is the breakaway friction's
excess over f_c,j: the friction that falls from f_c + f_s at rest to f_c in motion (the
Stribeck law of ``robot_sim``'s joints, docs/nodes.md). v_s is fixed, not fitted: the
model stays linear in θ. Real arms add two columns per joint (options): ``asymmetric``,
diag(|s(q')|), whose coefficient f_a,j makes the Coulomb friction f_c + f_a in the positive
direction and f_c − f_a in the negative one (gearboxes rarely rub alike both ways; with
``'sign'`` Coulomb, |s| = 1 is the offset's column, and with a narrow tanh nearly so: only
one of the two is then identified); and
``offsets``, a constant column per joint whose coefficient τ_0,j is the effort sensor's
offset (joint torque sensors drift, motor-current efforts carry a bias). An offset that the
rigid-body columns already hold (a vertical prismatic joint carries a constant weight) is
left out: :attr:`PhysicalModel.offset_joints` are the joints that have one. And a wrist
whose motors are coupled (the TX40's joints 5 and 6: one motor turns with q'_5 + q'_6)
carries each coupled motor's friction on both joints: ``coupled`` pairs (a, b) add to row a
viscous and Coulomb columns of q'_b, and to row b those of q'_a (on the TX40 they take
joint 5's held-out NMSE from 0.50 to 0.12, benchmarks/physical_real.md).

With ``consistent``, :meth:`PhysicalModel.fit` solves for physically consistent standard
parameters instead (positive masses, inertias a body can have: a pseudo-inertia LMI per
body, :mod:`~scara_ident_ros.dynamics.consistent_parameters`) as close to the least-squares
fit as the data allow; :attr:`PhysicalModel.standard_theta` holds them (what ``scara-ident
export --urdf`` writes).

where W_ind is the rigid-body regressor reduced to its base parameters θ_b
(:mod:`~scara_ident_ros.dynamics.base_reduction`, from the regressor stacked over seeded
random states). Friction columns are kept whole: rigid-body efforts hold no term linear in a
single joint's speed, so they are always identifiable.

The model is built from a URDF (file or string, as ``robot_description`` holds it) for the
joints named, in that order: the order of the recorded joint states, of the inputs
X = [q, q', q''] (N, 3n) and of the efforts (N, n), like the networks'. Other actuated joints
of the URDF (a gripper's fingers) are locked at their neutral position. Revolute, prismatic
and continuous joints are supported (a continuous joint's q is its angle). Gravity is
Pinocchio's, 9.81 m/s² along −z of the URDF's root.

:meth:`PhysicalModel.fit` (X, Y) and :meth:`PhysicalModel.fit_states` (q, q', q'', τ) are
linear least squares on the stacked regressor (QR of blocks of samples, memory bounded);
:meth:`PhysicalModel.predict` takes the networks' X: the model keeps the estimator contract
(:mod:`scara_ident_ros.estimator`) and stands wherever a network does (it learns online through
:class:`~scara_ident_ros.identification.rls_trainer.RecursiveLeastSquaresTrainer`, not
``partial_fit``). Files: ``.npz`` of kind ``'physical'`` (:mod:`scara_ident_ros.nn.model_file`),
holding the URDF text, the joints, the base reduction and θ.

Public API::

    COULOMB_MODES, COULOMB_EPS, INERTIAL_NAMES
    PhysicalModel(urdf, *, joint_names=None, coulomb='tanh', coulomb_eps=COULOMB_EPS,
                  armature=True, source='robot_description', stribeck_velocity=0.0,
                  asymmetric=False, offsets=False, coupled=(), consistent=False)
    PhysicalModel.from_urdf_file(path, **options)
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.dynamics.base_reduction import BaseReduction, reduce_columns
from scara_ident_ros.dynamics.joint_sizes import JointSizes
from scara_ident_ros.dynamics.least_squares import (RESIDUAL_WEIGHTS, BlockLeastSquares,
                                                    fit_least_squares)
from scara_ident_ros.dynamics.parameter_uncertainty import (ParameterUncertainty,
                                                            parameter_uncertainty)
from scara_ident_ros.dynamics.urdf_limits import UrdfError
from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.estimator import r2_score, register_kind
from scara_ident_ros.nn.errors import ModelFormatError
from scara_ident_ros.nn.model_file import read_model_file, write_model

__all__ = ['COULOMB_EPS', 'COULOMB_MODES', 'INERTIAL_NAMES', 'KIND', 'PhysicalModel']

FloatArray = NDArray[np.float64]

#: The 10 inertial parameters of a body, in Pinocchio's order (about the joint frame).
INERTIAL_NAMES = ('m', 'mx', 'my', 'mz', 'Ixx', 'Ixy', 'Iyy', 'Ixz', 'Iyz', 'Izz')
#: Coulomb friction shapes: ``'sign'`` (discontinuous at q' = 0), ``'tanh'`` (tanh(q'/ε)).
COULOMB_MODES = ('tanh', 'sign')
#: Default ε of tanh(q'/ε) (rad/s, m/s), the simulated SCARA's. Which ε fits depends on the
#: robot (benchmarks/physical.md): ``scara-ident train`` chooses it on validation data
#: (:mod:`~scara_ident_ros.dynamics.physical_options`) and falls back to this without any.
COULOMB_EPS = 0.05
KIND = 'physical'  #: the model file's kind
_REDUCTION_STATES = 200   # random states stacked for the base reduction
_REDUCTION_SEED = 0
_CHUNK = 2048             # samples per block of the least-squares fit


def _pinocchio() -> Any:
    try:
        import pinocchio  # a few hundred ms: only when a physical model is built
    except ImportError as exc:
        raise ScaraIdentError(f'the physical model needs Pinocchio (pip install pin): '
                              f'{exc}') from None
    return pinocchio


class PhysicalModel(JointSizes):
    """Inverse dynamics τ = Y(q, q', q'') θ of a URDF robot (module docstring).

    Parameters
    ----------
    urdf : str
        The URDF document (XML text).
    joint_names : sequence of str, optional
        The modelled joints, in the order of the inputs and efforts; default every
        non-fixed joint in Pinocchio's (depth-first) order.
    coulomb : {'tanh', 'sign'}
        Shape of the Coulomb term.
    coulomb_eps : float
        ε of tanh(q'/ε) (rad/s, m/s); unused with ``'sign'``.
    armature : bool
        Add a rotor-inertia column per joint.
    source : str
        Where the URDF came from, for messages.
    reduction : BaseReduction, optional
        A base reduction to use instead of computing one (a loaded model's).
    stribeck_velocity : float
        v_s (rad/s, m/s) of a Stribeck column per joint; 0: none.
    asymmetric : bool
        Add a column |s(q')| per joint: Coulomb friction that differs by direction.
    offsets : bool
        Add a constant effort offset per joint (where the rigid-body columns do not hold
        one: :attr:`offset_joints`).
    coupled : sequence of (str, str)
        Pairs of joints whose motors are coupled: each joint's row gets viscous and
        Coulomb columns of the other's speed.
    consistent : bool
        :meth:`fit` physically consistent parameters (module docstring), not plain least
        squares.
    weighted : bool
        :meth:`fit` by least squares weighted per joint by 1/its residual RMS after an
        unweighted fit (``fit_least_squares(weights='residual')``): a torso's or shoulder's
        large efforts no longer outweigh a wrist's, and each joint counts by its noise.

    Attributes
    ----------
    theta : ndarray of shape (n_parameters,)
        [θ_b, f_v, f_c] (then f_s with a Stribeck velocity, f_a if asymmetric, four per
        coupled pair, τ_0 of the :attr:`offset_joints` with offsets); zeros until
        :meth:`fit` (or
        :meth:`fit_states`, :meth:`set_theta`).
    offset_joints : ndarray of shape (n,) of bool
        The joints with an effort-offset column (none without ``offsets``).
    standard_theta : ndarray of shape (len(standard_names),) or None
        Physically consistent standard parameters of :attr:`theta` (a consistent fit's);
        None otherwise (:meth:`consistent_standard` finds some).
    metadata : dict of str to ndarray
        Saved with the model, as a network's (``joint_names``, ``method``, ...).
    residual_rms : ndarray of shape (n,) or None
        RMS effort residual per joint on the data of the last :meth:`fit` (N·m, N).
    uncertainty : ParameterUncertainty or None
        Each parameter's standard deviation and the regressor's condition number on the data
        of the last :meth:`fit` (:mod:`~scara_ident_ros.dynamics.parameter_uncertainty`);
        saved with the model.
    """

    #: The model file's kind (:func:`scara_ident_ros.estimator.load_model`).
    kind = KIND

    def __init__(self, urdf: str, *, joint_names: Sequence[str] | None = None,
                 coulomb: str = 'tanh', coulomb_eps: float = COULOMB_EPS,
                 armature: bool = True, source: str = 'robot_description',
                 reduction: BaseReduction | None = None,
                 stribeck_velocity: float = 0.0, asymmetric: bool = False,
                 offsets: bool = False,
                 coupled: Sequence[tuple[str, str]] = (),
                 consistent: bool = False, weighted: bool = False) -> None:
        if not stribeck_velocity >= 0.0:
            raise ValueError(f'stribeck_velocity must be >= 0, got {stribeck_velocity!r}')
        self.stribeck_velocity = float(stribeck_velocity)
        self.asymmetric, self.offsets = bool(asymmetric), bool(offsets)
        self.consistent, self.weighted = bool(consistent), bool(weighted)
        self.standard_theta: FloatArray | None = None
        if coulomb not in COULOMB_MODES:
            raise ValueError(f'coulomb must be one of {COULOMB_MODES}, got {coulomb!r}')
        if not coulomb_eps > 0.0:
            raise ValueError(f'coulomb_eps must be > 0, got {coulomb_eps!r}')
        pin = _pinocchio()
        self.urdf, self.source = urdf, source
        self.coulomb, self.coulomb_eps, self.armature = coulomb, float(coulomb_eps), armature
        try:
            full = pin.buildModelFromXML(urdf)
        except (RuntimeError, ValueError) as exc:
            raise UrdfError(f'{source}: Pinocchio cannot build a model: '
                            f'{" ".join(str(exc).split())}') from None
        actuated = [name for jid, name in enumerate(full.names)
                    if jid > 0 and full.joints[jid].nv > 0]
        names = list(actuated if joint_names is None else joint_names)
        missing = [name for name in names if name not in actuated]
        if missing or len(set(names)) != len(names) or not names:
            raise UrdfError(f'{source}: joints {names} are not distinct joints of the URDF '
                            f'(its moving joints: {actuated}); missing: {missing}')
        lock = [full.getJointId(name) for name in actuated if name not in names]
        model = (pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full)
        self._pin, self._model, self._data = pin, model, model.createData()
        self.joint_names = tuple(names)
        self._n = len(names)
        self._q_index, self._circle, self._v_index = [], [], []
        for name in names:
            joint = model.joints[model.getJointId(name)]
            if joint.nv != 1 or joint.nq not in (1, 2):
                raise UrdfError(f'{source}: joint {name!r} has {joint.nv} degrees of freedom; '
                                'only revolute, prismatic and continuous joints are modelled')
            self._q_index.append(joint.idx_q)
            self._circle.append(joint.nq == 2)
            self._v_index.append(joint.idx_v)
        self._q_index_array = np.array(self._q_index)
        self._v_index_array = np.array(self._v_index)
        self._q_neutral = pin.neutral(model)
        self._bodies = [self._body_name(jid) for jid in range(1, model.njoints)]
        self.standard_names = tuple(
            [f'{body}.{p}' for body in self._bodies for p in INERTIAL_NAMES]
            + ([f'{name}.Ia' for name in names] if armature else []))
        self.reduction = reduction if reduction is not None else self._reduce()
        if self.reduction.names != self.standard_names:
            raise ModelFormatError(f'{source}: the base reduction is for parameters '
                                   f'{self.reduction.names[:3]}..., this URDF has '
                                   f'{self.standard_names[:3]}...')
        self.coupled = tuple((str(a), str(b)) for a, b in coupled)
        if any(a not in names or b not in names or a == b for a, b in self.coupled):
            raise UrdfError(f'{source}: coupled joints {list(self.coupled)} must be pairs of '
                            f'distinct modelled joints ({names})')
        # (row, speed) joint index pairs of the coupling columns: viscous, then Coulomb
        self._coupling = np.array([pair for a, b in self.coupled for pair in
                                   ((names.index(a), names.index(b)),
                                    (names.index(b), names.index(a)))],
                                  dtype=np.int64).reshape(-1, 2)
        self.offset_joints = (self._identifiable_offsets() if self.offsets
                              else np.zeros(self._n, dtype=bool))
        self.parameter_names = (self.reduction.base_names
                                + tuple(f'{name}.fv' for name in names)
                                + tuple(f'{name}.fc' for name in names)
                                + (tuple(f'{name}.fs' for name in names)
                                   if self.stribeck_velocity > 0.0 else ())
                                + (tuple(f'{name}.fa' for name in names)
                                   if self.asymmetric else ())
                                + tuple(f'{names[r]}.{kind}[{names[c]}]' for kind in ('fv', 'fc')
                                        for r, c in self._coupling)
                                + tuple(f'{name}.offset' for name, kept in
                                        zip(names, self.offset_joints) if kept))
        self.theta: FloatArray = np.zeros(len(self.parameter_names))
        self.residual_rms: FloatArray | None = None
        self.uncertainty: ParameterUncertainty | None = None
        self.metadata: dict[str, np.ndarray] = {'joint_names': np.array(names)}

    @classmethod
    def from_urdf_file(cls, path: str | Path, **options: Any) -> PhysicalModel:
        """Build from the URDF file at ``path``; ``options`` as the constructor's."""
        try:
            text = Path(path).read_text(encoding='utf-8')
        except (OSError, UnicodeDecodeError) as exc:
            raise UrdfError(f'{path}: cannot read the URDF: {exc}') from None
        return cls(text, source=str(path), **options)

    # ------------------------------------------------- sizes (n_joints, ...: JointSizes)
    @property
    def n_parameters(self) -> int:
        """Length of θ: base parameters plus the friction coefficients and offsets."""
        return len(self.parameter_names)

    @property
    def n_bodies(self) -> int:
        """Number of moving bodies (10 standard parameters each)."""
        return int(self._model.njoints) - 1

    @property
    def body_names(self) -> tuple[str, ...]:
        """The link each body is named after (its joint's child link), in body order."""
        return tuple(self._bodies)

    @property
    def n_base(self) -> int:
        """Number of rigid-body (and armature) base parameters."""
        return self.reduction.n_base

    @property
    def method(self) -> str:
        """The method key: ``metadata['method']`` if recorded, else the kind."""
        return str(self.metadata.get('method', KIND))

    def get_params(self) -> dict[str, Any]:
        """The constructor's hyperparameters (URDF text and source, joints, friction law,
        armature, real-arm terms, consistent fit), as data."""
        return {'urdf': self.urdf, 'joint_names': list(self.joint_names),
                'coulomb': self.coulomb, 'coulomb_eps': self.coulomb_eps,
                'armature': self.armature, 'source': self.source,
                'stribeck_velocity': self.stribeck_velocity, 'asymmetric': self.asymmetric,
                'offsets': self.offsets, 'coupled': [list(pair) for pair in self.coupled],
                'consistent': self.consistent, 'weighted': self.weighted}

    # ------------------------------------------------------------------------- regressors
    def standard_regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """Regressor of the standard parameters :attr:`standard_names` (no friction).

        Parameters
        ----------
        q, qd, qdd : array_like of shape (N, n) or (n,)
            Joint positions, velocities and accelerations (SI), in :attr:`joint_names` order.

        Returns
        -------
        ndarray of shape (N, n, P) or (n, P)
            Row j maps the standard parameters to the effort of joint j (N·m or N).
        """
        (q, qd, qdd), single = self._states(q, qd, qdd)
        pin, model, data = self._pin, self._model, self._data
        count, n = q.shape[0], self._n
        n_inertial = 10 * (model.njoints - 1)
        out = np.zeros((count, n, len(self.standard_names)))
        qi, vi = self._q_index_array, self._v_index_array
        circle = np.array(self._circle)
        qp = np.tile(self._q_neutral, (count, 1))  # Pinocchio's configurations
        qp[:, qi[~circle]] = q[:, ~circle]
        qp[:, qi[circle]] = np.cos(q[:, circle])
        qp[:, qi[circle] + 1] = np.sin(q[:, circle])
        vp, ap = np.zeros((count, model.nv)), np.zeros((count, model.nv))
        vp[:, vi], ap[:, vi] = qd, qdd
        rows = None if np.array_equal(vi, np.arange(n)) else vi
        regressor = pin.computeJointTorqueRegressor
        for k in range(count):
            w = regressor(model, data, qp[k], vp[k], ap[k])
            out[k, :, :n_inertial] = w if rows is None else w[rows]
        if self.armature:
            joints = np.arange(n)
            out[:, joints, n_inertial + joints] = qdd
        return out[0] if single else out

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """Regressor Y of θ (:attr:`parameter_names`): base columns, then friction.

        Parameters
        ----------
        q, qd, qdd : array_like of shape (N, n) or (n,)
            Joint positions, velocities and accelerations (SI).

        Returns
        -------
        ndarray of shape (N, n, n_parameters) or (n, n_parameters)
            τ = Y θ.
        """
        (q, qd, qdd), single = self._states(q, qd, qdd)
        out = self.regressor_from_base(self.base_regressor(q, qd, qdd), qd)
        return out[0] if single else out

    def base_regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """The rigid-body and rotor-inertia part of :meth:`regressor`: (N, n, n_base).

        It depends on the URDF and the joints only, not on the friction law: models that
        differ in their Coulomb shape share it (:meth:`regressor_from_base`).
        """
        return self.reduction.reduce(self.standard_regressor(q, qd, qdd))

    def regressor_from_base(self, base: ArrayLike, qd: ArrayLike) -> FloatArray:
        """:meth:`regressor` from its base part (N, n, n_base) and the speeds qd (N, n)."""
        base = np.asarray(base, dtype=np.float64)
        qd = np.asarray(qd, dtype=np.float64)
        n, nb = self._n, self.n_base
        if base.ndim != 3 or base.shape[1:] != (n, nb) or qd.shape != base.shape[:2]:
            raise ValueError(f'need a base regressor (N, {n}, {nb}) and qd (N, {n}), got '
                             f'{base.shape} and {qd.shape}')
        out = np.zeros((base.shape[0], n, self.n_parameters))
        out[:, :, :nb] = base
        joints = np.arange(n)
        out[:, joints, nb + joints] = qd
        shape = self.coulomb_shape(qd)
        out[:, joints, nb + n + joints] = shape
        column = nb + 2 * n
        if self.stribeck_velocity > 0.0:
            out[:, joints, column + joints] = (
                np.exp(-(qd / self.stribeck_velocity) ** 2) * shape)
            column += n
        if self.asymmetric:
            out[:, joints, column + joints] = np.abs(shape)
            column += n
        rows, speeds = self._coupling[:, 0], self._coupling[:, 1]
        pairs = np.arange(rows.size)
        out[:, rows, column + pairs] = qd[:, speeds]
        out[:, rows, column + rows.size + pairs] = shape[:, speeds]
        column += 2 * rows.size
        kept = np.flatnonzero(self.offset_joints)
        out[:, kept, column + np.arange(kept.size)] = 1.0
        return out

    def stacked_regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """:meth:`regressor` with the joints' rows stacked: shape (N·n, n_parameters)."""
        return self.regressor(np.atleast_2d(q), np.atleast_2d(qd),
                              np.atleast_2d(qdd)).reshape(-1, self.n_parameters)

    def coulomb_shape(self, qd: ArrayLike) -> FloatArray:
        """s(q'): sign(q') or tanh(q'/ε), same shape as ``qd``."""
        qd = np.asarray(qd, dtype=np.float64)
        if self.coulomb == 'sign':
            return np.sign(qd)
        return np.tanh(qd / self.coulomb_eps)

    # ------------------------------------------------------------------------- parameters
    def urdf_parameters(self) -> FloatArray:
        """θ of the URDF's own inertias (armature from Pinocchio, friction 0): a prior.

        Returns
        -------
        ndarray of shape (n_parameters,)
        """
        return np.concatenate([self.reduction.base_values(self.urdf_standard_parameters()),
                               np.zeros(self.n_parameters - self.n_base)])

    def urdf_standard_parameters(self) -> FloatArray:
        """The URDF's own standard parameters (:attr:`standard_names`), shape (P,)."""
        model = self._model
        inertial = [model.inertias[jid].toDynamicParameters() for jid in range(1, model.njoints)]
        return np.concatenate(inertial + ([np.asarray(model.armature)[self._v_index_array]]
                                          if self.armature else []))

    def consistent_standard(self) -> FloatArray:
        """Physically consistent standard parameters of the model (P,): those of a consistent
        fit, else the consistent ones whose base parameters are nearest :attr:`theta`'s
        (friction kept as it is)."""
        if self.standard_theta is not None:
            return self.standard_theta.copy()
        from scara_ident_ros.dynamics.consistent_parameters import consistent_fit
        p = self.n_parameters
        rows = np.hstack([np.eye(p), self.theta[:, None]])
        return consistent_fit(self, rows).standard

    def set_theta(self, theta: ArrayLike) -> None:
        """Set θ (n_parameters,), e.g. an online estimate."""
        value = np.asarray(theta, dtype=np.float64).reshape(-1)
        if value.shape != self.theta.shape or not np.all(np.isfinite(value)):
            raise ValueError(f'theta must be {self.theta.shape[0]} finite values, got '
                             f'shape {value.shape}')
        self.theta = value.copy()
        self.standard_theta = None
        self.uncertainty = None

    @property
    def base_parameters(self) -> dict[str, float]:
        """Identified base parameters by name (SI: kg, kg·m, kg·m²)."""
        nb = self.n_base
        return dict(zip(self.parameter_names[:nb], self.theta[:nb].tolist()))

    @property
    def viscous(self) -> FloatArray:
        """Viscous friction per joint (N·m·s/rad, N·s/m), shape (n,)."""
        return self.theta[self.n_base:self.n_base + self._n].copy()

    @property
    def coulomb_friction(self) -> FloatArray:
        """Coulomb friction per joint (N·m, N), shape (n,)."""
        start = self.n_base + self._n
        return self.theta[start:start + self._n].copy()

    @property
    def stribeck_friction(self) -> FloatArray:
        """Breakaway excess f_s per joint (N·m, N), shape (n,); zeros without a Stribeck
        velocity."""
        if self.stribeck_velocity == 0.0:
            return np.zeros(self._n)
        start = self.n_base + 2 * self._n
        return self.theta[start:start + self._n].copy()

    @property
    def asymmetric_friction(self) -> FloatArray:
        """f_a per joint (N·m, N), shape (n,): the Coulomb friction is f_c + f_a moving in
        the positive direction, f_c − f_a in the negative; zeros unless ``asymmetric``."""
        if not self.asymmetric:
            return np.zeros(self._n)
        start = self.n_base + (3 if self.stribeck_velocity > 0.0 else 2) * self._n
        return self.theta[start:start + self._n].copy()

    @property
    def effort_offset(self) -> FloatArray:
        """The effort offset τ_0 per joint (N·m, N), shape (n,); 0 where there is none."""
        out = np.zeros(self._n)
        kept = int(np.count_nonzero(self.offset_joints))
        if kept:
            out[self.offset_joints] = self.theta[self.n_parameters - kept:]
        return out

    @property
    def friction(self) -> dict[str, tuple[float, float]]:
        """Joint name → (viscous, Coulomb) coefficients."""
        return {name: (float(v), float(c)) for name, v, c in
                zip(self.joint_names, self.viscous, self.coulomb_friction)}

    def definitions(self) -> tuple[str, ...]:
        """What each base parameter is in standard parameters (``BaseReduction``)."""
        return self.reduction.definitions()

    # ------------------------------------------------------------------------ fit, predict
    def fit(self, X: ArrayLike, Y: ArrayLike) -> PhysicalModel:
        """:meth:`fit_states` on the networks' layout: X (N, 3n) = [q, q', q''], Y (N, n).

        Returns
        -------
        PhysicalModel
            ``self``, with :attr:`theta` and :attr:`residual_rms` set.
        """
        q, qd, qdd = self._split(X)
        return self.fit_states(q, qd, qdd, Y)

    def fit_states(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
                   tau: ArrayLike) -> PhysicalModel:
        """θ by linear least squares, min Σ ||Y θ − τ||² (weighted per joint if
        :attr:`weighted`), over all samples.

        :func:`~scara_ident_ros.dynamics.least_squares.fit_least_squares` of the states and
        efforts (its parameters): the stacked system is reduced block by block, so memory
        does not grow with the samples.

        Returns
        -------
        PhysicalModel
            ``self``, with :attr:`theta` and :attr:`residual_rms` set.
        """
        (q, qd, qdd), _ = self._states(q, qd, qdd)
        weights = RESIDUAL_WEIGHTS if self.weighted else None
        if not self.consistent:
            fit = fit_least_squares(self, q, qd, qdd, tau, block=_CHUNK, weights=weights)
            self.theta, self.residual_rms, self.standard_theta = fit.theta, fit.residual_rms, None
            self.uncertainty = parameter_uncertainty(self, q, qd, qdd, tau, self.theta,
                                                     weights=fit.weights)
            return self
        from scara_ident_ros.dynamics.consistent_parameters import consistent_fit
        solution: list[FloatArray] = []

        def solve(system: BlockLeastSquares) -> FloatArray:
            found = consistent_fit(self, system.upper)
            solution.append(found.standard)
            return found.theta

        fit = fit_least_squares(self, q, qd, qdd, tau, block=_CHUNK, solve=solve,
                                weights=weights)
        self.theta, self.residual_rms = fit.theta, fit.residual_rms
        self.standard_theta = solution[0]
        self.uncertainty = parameter_uncertainty(self, q, qd, qdd, tau, self.theta,
                                                 weights=fit.weights)
        return self

    def predict(self, X: ArrayLike) -> FloatArray:
        """Efforts Y θ for X = [q, q', q''] of shape (N, 3n), or (3n,) for one sample.

        Returns
        -------
        ndarray of shape (N, n) or (n,)
            Efforts (N·m, N), a new array.
        """
        x = np.asarray(X, dtype=np.float64)
        q, qd, qdd = self._split(np.atleast_2d(x))
        tau = np.concatenate([self.regressor(q[s:s + _CHUNK], qd[s:s + _CHUNK],
                                             qdd[s:s + _CHUNK]) @ self.theta
                              for s in range(0, q.shape[0], _CHUNK)]) if q.shape[0] else \
            np.zeros((0, self._n))
        return tau[0] if x.ndim == 1 else tau

    def score(self, X: ArrayLike, Y: ArrayLike) -> float:
        """R² of the predictions of Y (N, n) from X (N, 3n)
        (:func:`scara_ident_ros.estimator.r2_score`)."""
        return r2_score(Y, self.predict(X))

    def partial_fit(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        """Not a per-sample gradient model: learn online with the RLS trainer instead.

        Raises
        ------
        NotImplementedError
            Always (see ``identification.rls_trainer``).
        """
        raise NotImplementedError('a PhysicalModel learns online through '
                                  'RecursiveLeastSquaresTrainer, not partial_fit')

    # --------------------------------------------------------------------------- files
    def to_arrays(self) -> dict[str, np.ndarray]:
        """The entries that :meth:`from_arrays` rebuilds the model from."""
        r = self.reduction
        return {'urdf': np.array(self.urdf), 'joints': np.array(self.joint_names),
                'coulomb': np.array(self.coulomb),
                'coulomb_eps': np.array(self.coulomb_eps),
                'armature': np.array(self.armature), 'standard_names': np.array(r.names),
                'stribeck_velocity': np.array(self.stribeck_velocity),
                'asymmetric': np.array(self.asymmetric), 'offsets': np.array(self.offsets),
                'coupled': np.array(self.coupled, dtype=str).reshape(-1, 2),
                'consistent': np.array(self.consistent),
                'weighted': np.array(self.weighted),
                'independent': r.independent.astype(np.int64),
                'dependent': r.dependent.astype(np.int64), 'beta': r.beta.copy(),
                'theta': self.theta.copy(),
                **({} if self.standard_theta is None else
                   {'standard_theta': self.standard_theta.copy()}),
                **({} if self.uncertainty is None else
                   {'theta_std': self.uncertainty.std.copy(),
                    'condition_number': np.array(self.uncertainty.condition_number)})}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], *, source: str) -> PhysicalModel:
        """Rebuild a model from :meth:`to_arrays`' entries.

        Raises
        ------
        ModelFormatError
            If an entry is missing, has the wrong type or shape, or does not fit the URDF.
        """
        try:
            names = tuple(str(s) for s in np.atleast_1d(arrays['standard_names']))
            reduction = BaseReduction(names, np.asarray(arrays['independent'], np.int64),
                                      np.asarray(arrays['dependent'], np.int64),
                                      np.asarray(arrays['beta'], np.float64))
            model = cls(str(arrays['urdf']),
                        joint_names=[str(s) for s in np.atleast_1d(arrays['joints'])],
                        coulomb=str(arrays['coulomb']),
                        coulomb_eps=float(arrays['coulomb_eps']),
                        armature=bool(arrays['armature']), source=source,
                        reduction=reduction,
                        stribeck_velocity=float(arrays.get('stribeck_velocity', 0.0)),
                        asymmetric=bool(arrays.get('asymmetric', False)),
                        offsets=bool(arrays.get('offsets', False)),
                        coupled=[(str(a), str(b)) for a, b in
                                 np.asarray(arrays.get('coupled', np.zeros((0, 2), str)))
                                 .reshape(-1, 2)],
                        consistent=bool(arrays.get('consistent', False)),
                        weighted=bool(arrays.get('weighted', False)))
            model.set_theta(arrays['theta'])
            if 'standard_theta' in arrays:
                standard = np.asarray(arrays['standard_theta'], np.float64)
                if standard.shape != (len(model.standard_names),):
                    raise ValueError(f'standard_theta of shape {standard.shape}')
                model.standard_theta = standard
            if 'theta_std' in arrays:
                model.uncertainty = ParameterUncertainty(
                    model.parameter_names, model.theta.copy(),
                    np.asarray(arrays['theta_std'], np.float64).reshape(model.theta.shape),
                    float(arrays['condition_number']))
        except (KeyError, ValueError, TypeError) as exc:
            raise ModelFormatError(f'{source}: corrupt physical model: '
                                   f'{" ".join(str(exc).split())}') from None
        return model

    def save(self, path: str | Path) -> None:
        """Write the model (kind ``'physical'``) with its :attr:`metadata`, atomically."""
        write_model(path, self.to_arrays(), self.metadata, kind=KIND)

    @classmethod
    def load(cls, path: str | Path) -> PhysicalModel:
        """Read a model written by :meth:`save`.

        Raises
        ------
        ModelFormatError
            If the file is not a physical model of ours or is corrupt.
        """
        file = read_model_file(path, kind=KIND)
        model = cls.from_arrays(file.arrays, source=str(path))
        model.metadata = file.metadata
        return model

    def __repr__(self) -> str:
        return (f'PhysicalModel({self.source!r}, joints={list(self.joint_names)}, '
                f'{self.n_base} base + {self.n_parameters - self.n_base} friction and '
                'offset parameters, '
                f'coulomb={self.coulomb!r})')

    # ---------------------------------------------------------------------------- helpers
    def _reduce(self) -> BaseReduction:
        """Base reduction from the standard regressor at seeded random states."""
        rng = np.random.default_rng(_REDUCTION_SEED)
        low = np.asarray(self._model.lowerPositionLimit)[self._q_index_array]
        high = np.asarray(self._model.upperPositionLimit)[self._q_index_array]
        bounded = np.isfinite(low) & np.isfinite(high) & (high > low) & ~np.array(self._circle)
        low = np.where(bounded, low, -np.pi)
        high = np.where(bounded, high, np.pi)
        count, n = _REDUCTION_STATES, self._n
        q = rng.uniform(low, high, (count, n))
        w = self.standard_regressor(q, rng.normal(0.0, 1.0, (count, n)),
                                    rng.normal(0.0, 1.0, (count, n)))
        return reduce_columns(w.reshape(-1, len(self.standard_names)), self.standard_names)

    def _identifiable_offsets(self) -> NDArray[np.bool_]:
        """Joints whose constant effort column is not in the span of the base columns
        (stacked over the base reduction's random states): shape (n,) of bool."""
        rng = np.random.default_rng(_REDUCTION_SEED + 1)
        count, n = _REDUCTION_STATES, self._n
        w = self.base_regressor(rng.uniform(-np.pi, np.pi, (count, n)),
                                rng.normal(0.0, 1.0, (count, n)),
                                rng.normal(0.0, 1.0, (count, n))).reshape(count * n, -1)
        kept = np.zeros(n, dtype=bool)
        for j in range(n):
            constant = np.zeros((count, n))
            constant[:, j] = 1.0
            column = constant.reshape(-1)
            fit, *_ = np.linalg.lstsq(w, column, rcond=None)
            kept[j] = np.linalg.norm(w @ fit - column) > 1e-6 * np.linalg.norm(column)
        return kept

    def _body_name(self, jid: int) -> str:
        """The link a joint moves: its first body frame (or the joint's name)."""
        for frame in self._model.frames:
            if frame.parentJoint == jid and frame.type == self._pin.FrameType.BODY:
                return str(frame.name)
        return str(self._model.names[jid])

    def _states(self, *arrays: ArrayLike) -> tuple[list[FloatArray], bool]:
        """Arrays as float (N, n); whether they were single samples (n,)."""
        values = [np.asarray(a, dtype=np.float64) for a in arrays]
        single = values[0].ndim == 1
        values = [np.atleast_2d(v) for v in values]
        shape = values[0].shape
        if shape[1:] != (self._n,) or any(v.shape != shape for v in values):
            raise ValueError(f'q, qd, qdd must all have shape (N, {self._n}) or '
                             f'({self._n},), got {[v.shape for v in values]}')
        return values, single

    def _split(self, X: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        x = np.asarray(X, dtype=np.float64)
        n = self._n
        if x.ndim != 2 or x.shape[1] != 3 * n:
            raise ValueError(f'X must have shape (N, {3 * n}) = [q, qd, qdd], got {x.shape}')
        return x[:, :n], x[:, n:2 * n], x[:, 2 * n:]


register_kind(KIND, PhysicalModel.load)
