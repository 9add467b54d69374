"""A robot's joint limits by joint name, read from its files: what scales the network,
bounds the samples and keeps an excitation's motion in range.

:func:`load_joint_limits` takes them, as the identifier's parameters say, from a URDF (file
or ``robot_description``, with acceleration limits from ``acceleration_max`` or the robot
YAML), from five explicit lists with their joint names, or from the robot YAML
(``config/scara.yaml`` unless another is given). :meth:`JointLimits.select` orders them for
the identifier's joints; :meth:`JointLimits.scaling` gives the network's input/output ranges
(`identification.sample_check.joint_bounds` the values a sample may have).

An excitation on a real arm takes the same limits with :func:`load_motion_limits` (a URDF
required, every error in one line), keeps to :meth:`JointLimits.with_margins`
(``position_margin`` of each range clear at both ends, ``velocity_scale`` and
``acceleration_scale`` of the limits) and checks its samples with
:meth:`JointLimits.violations`.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from scara_ident_ros.dynamics import ParamError, ScaraParams
from scara_ident_ros.dynamics.urdf_limits import UrdfError, UrdfLimits, parse_urdf, read_urdf
from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.resources import config_path

__all__ = ['LIMIT_NAMES', 'TOLERANCE', 'JointLimits', 'LimitsError', 'load_joint_limits',
           'load_motion_limits']

#: The limits of each joint, in the order of :class:`JointLimits`' arrays.
LIMIT_NAMES = ('position_min', 'position_max', 'velocity_max', 'acceleration_max',
               'effort_max')
#: Relative tolerance of :meth:`JointLimits.violations` (rounding of sampled values).
TOLERANCE = 1e-9


class LimitsError(ScaraIdentError, ValueError):
    """Joint limits missing, unusable or given twice, margins out of range, or motion that
    cannot keep to the limits (a one-line message)."""


@dataclass(frozen=True)
class JointLimits:
    """Joint limits by joint name.

    Attributes
    ----------
    names : tuple of str of length n
        The joints, distinct, in the order of the arrays.
    position_min, position_max : ndarray of shape (n,)
        Position range (rad or m), ``position_min < position_max``.
    velocity_max, acceleration_max, effort_max : ndarray of shape (n,)
        Symmetric limits of velocity (rad/s, m/s), acceleration (rad/s², m/s²) and effort
        (N·m, N), > 0.
    source : str
        Where they come from (a URDF's path, ``'robot_description'``, ``'robot_config'``).

    Raises
    ------
    LimitsError
        For arrays of another length, values not finite, an empty range or a limit <= 0.
    """

    names: tuple[str, ...]
    position_min: NDArray[np.float64]
    position_max: NDArray[np.float64]
    velocity_max: NDArray[np.float64]
    acceleration_max: NDArray[np.float64]
    effort_max: NDArray[np.float64]
    source: str = 'robot_config'

    def __post_init__(self) -> None:
        n = len(self.names)
        if len(set(self.names)) != n:
            raise LimitsError(f'{self.source}: joint names must be distinct, got {self.names}')
        for key in LIMIT_NAMES:
            value = np.array(getattr(self, key), dtype=float)
            if value.shape != (n,) or not np.all(np.isfinite(value)):
                raise LimitsError(f'{self.source}: {key} must be {n} finite values, got '
                                  f'{" ".join(repr(value).split())}')
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        if np.any(self.position_min >= self.position_max):
            raise LimitsError(f'{self.source}: position_min must be below position_max')
        if min(np.min(getattr(self, key), initial=1.0) for key in LIMIT_NAMES[2:]) <= 0.0:
            raise LimitsError(f'{self.source}: velocity, acceleration and effort limits must '
                              'be > 0')

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return len(self.names)

    @property
    def centre(self) -> NDArray[np.float64]:
        """Middle of each joint's range, shape (n,) (rad or m)."""
        return 0.5 * (self.position_min + self.position_max)

    @classmethod
    def of(cls, names: Sequence[str], limits: Mapping[str, npt.ArrayLike],
           source: str = 'robot_config') -> JointLimits:
        """From ``limits[key]`` for each key of :data:`LIMIT_NAMES`, a value per joint."""
        a = {key: np.asarray(limits[key], float) for key in LIMIT_NAMES}
        return cls(tuple(names), a['position_min'], a['position_max'], a['velocity_max'],
                   a['acceleration_max'], a['effort_max'], source)

    @classmethod
    def from_urdf(cls, urdf: UrdfLimits, acceleration_max: Mapping[str, float], *,
                  required: Sequence[str] = ()) -> JointLimits:
        """A URDF's limits for its joints that have an acceleration limit (rad/s² or m/s²,
        by joint name: URDF has none), in the URDF's order.

        Raises
        ------
        UrdfError
            Naming the ``required`` joints without limits or acceleration limit.
        """
        urdf.select(required)
        lacking = [name for name in required if name not in acceleration_max]
        if lacking:
            raise UrdfError(f'{urdf.source}: no acceleration limit for {lacking} (URDF has '
                            'none): give acceleration_max for joint_names, or a robot_config '
                            'naming them')
        chosen = urdf.select([name for name in urdf.names if name in acceleration_max])
        return cls(chosen.names, chosen.position_min, chosen.position_max,
                   chosen.velocity_max,
                   np.array([float(acceleration_max[n]) for n in chosen.names]),
                   chosen.effort_max, urdf.source)

    def missing(self, names: Sequence[str]) -> list[str]:
        """The joints of ``names`` without limits here."""
        return [name for name in names if name not in self.names]

    def select(self, names: Sequence[str]) -> JointLimits:
        """The limits of ``names``, in that order.

        Raises
        ------
        LimitsError
            Naming the joints of ``names`` without limits here.
        """
        missing = self.missing(names)
        if missing:
            raise LimitsError(f'no joint limits for {missing} (limits are known for '
                              f'{list(self.names)}, from {self.source})')
        order = [self.names.index(name) for name in names]
        return replace(self, names=tuple(names),
                       **{key: getattr(self, key)[order] for key in LIMIT_NAMES})

    def scaling(self) -> tuple[NDArray[np.float64], ...]:
        """The network's ``x_min, x_max`` (3n,) and ``y_min, y_max`` (n,): see
        :func:`~scara_ident_ros.nn.presets.limit_scaling`."""
        # imported here: the networks are not needed by the excitation, which uses the rest
        from scara_ident_ros.nn.presets import limit_scaling

        return limit_scaling(*(getattr(self, key) for key in LIMIT_NAMES))

    def with_margins(self, position_margin: float, velocity_scale: float,
                     acceleration_scale: float) -> JointLimits:
        """These limits less ``position_margin`` (in [0, 0.5)) of each range at each end and
        scaled by ``velocity_scale`` and ``acceleration_scale`` (in (0, 1]); efforts as they
        are."""
        if not 0.0 <= position_margin < 0.5:
            raise LimitsError(f'position_margin must be in [0, 0.5), got {position_margin!r}')
        for name, value in (('velocity_scale', velocity_scale),
                            ('acceleration_scale', acceleration_scale)):
            if not 0.0 < value <= 1.0:
                raise LimitsError(f'{name} must be in (0, 1], got {value!r}')
        clear = position_margin * (self.position_max - self.position_min)
        return replace(self, position_min=self.position_min + clear,
                       position_max=self.position_max - clear,
                       velocity_max=velocity_scale * self.velocity_max,
                       acceleration_max=acceleration_scale * self.acceleration_max,
                       source=f'{self.source} with margins')

    def outside(self, q: NDArray[np.float64]) -> list[str]:
        """The joints whose position in ``q`` (n,) is outside the range, as text."""
        return [f'{name} = {value:g} not in [{low:g}, {high:g}]' for name, value, low, high
                in zip(self.names, q, self.position_min, self.position_max)
                if not low <= value <= high]

    def violations(self, q: NDArray[np.float64], qd: NDArray[np.float64],
                   qdd: NDArray[np.float64], *,
                   position_hull: NDArray[np.float64] | None = None) -> list[str]:
        """What sampled motion breaks of the position, velocity and acceleration limits, one
        text per kind and joint.

        ``q``, ``qd``, ``qdd`` are (N, n) (rad or m, /s, /s²); ``position_hull`` (n,) is a
        position also allowed, with every position between it and the range (an approach's
        start in the margins). Empty when all is within the limits (up to
        :data:`TOLERANCE`).
        """
        low, high = self.position_min, self.position_max
        if position_hull is not None:
            low, high = np.minimum(low, position_hull), np.maximum(high, position_hull)
        slack = TOLERANCE * (1.0 + np.abs(high - low))
        found = []
        for j, name in enumerate(self.names):
            if np.any(q[:, j] < low[j] - slack[j]) or np.any(q[:, j] > high[j] + slack[j]):
                found.append(f'{name}: position {q[:, j].min():g}..{q[:, j].max():g} outside '
                             f'[{low[j]:g}, {high[j]:g}]')
            for label, values, limit in (('velocity', qd, self.velocity_max),
                                         ('acceleration', qdd, self.acceleration_max)):
                peak = float(np.abs(values[:, j]).max(initial=0.0))
                if peak > limit[j] * (1.0 + TOLERANCE):
                    found.append(f'{name}: |{label}| {peak:g} above {limit[j]:g}')
        return found


def load_joint_limits(*, joint_names: Sequence[str] = (), robot_config: str = '',
                      urdf_file: str = '', robot_description: str = '',
                      explicit: Mapping[str, Sequence[float]] | None = None,
                      partial: bool = False) -> JointLimits:
    """The joint limits the identifier's parameters name.

    Parameters
    ----------
    joint_names : sequence of str
        The joints to identify (may be empty); explicit limits and ``acceleration_max``
        with a URDF give one value per name.
    robot_config : str
        Robot YAML; empty: the installed ``config/scara.yaml``.
    urdf_file, robot_description : str
        A URDF file or text (at most one): its position, velocity and effort limits.
    explicit : mapping of str to sequence of float
        ``position_min`` ... ``effort_max`` (:data:`LIMIT_NAMES`), each empty or one value
        per joint of ``joint_names``.
    partial : bool
        With a URDF: accept ``joint_names`` that it has without all limits (no acceleration
        limit, continuous): they are left out, for the stream to complete
        (:mod:`~scara_ident_ros.identification.stream_scaling`); only joints the URDF does
        not have are refused.

    Raises
    ------
    LimitsError, UrdfError, ParamError
        With a one-line message saying which parameter is wrong.
    """
    explicit = {key: (explicit or {}).get(key, ()) for key in LIMIT_NAMES}
    robot_yaml = robot_config or config_path('scara.yaml')
    if urdf_file or robot_description:
        return _urdf_limits(joint_names, robot_yaml, urdf_file, robot_description, explicit,
                            partial=partial, chosen=bool(robot_config))
    given = [key for key in LIMIT_NAMES if len(explicit[key])]
    if given:
        lengths = {len(explicit[key]) for key in LIMIT_NAMES}
        if len(given) != len(LIMIT_NAMES) or len(lengths) != 1:
            raise LimitsError('parameters ' + ', '.join(LIMIT_NAMES) +
                              ' must all be given, with one value per joint')
        if not joint_names or len(joint_names) != lengths.pop():
            raise LimitsError('explicit joint limits need joint_names with one name per '
                              'limit value')
        return JointLimits.of(joint_names, explicit, source='parameters')
    robot = ScaraParams.from_yaml(robot_yaml)
    return JointLimits.of(robot.joint_names, {key: robot.array(key) for key in LIMIT_NAMES})


def _urdf_limits(joint_names: Sequence[str], robot_yaml: str | Path, urdf_file: str,
                 robot_description: str, explicit: Mapping[str, Sequence[float]], *,
                 partial: bool = False, chosen: bool = True) -> JointLimits:
    """A URDF's limits, with acceleration limits from ``acceleration_max`` or the robot YAML
    (the default one, not ``chosen``, only for a URDF of its joints: another arm's joints
    may share its names, ``joint1``...)."""
    if urdf_file and robot_description:
        raise LimitsError('give urdf_file or robot_description, not both')
    clash = [key for key in LIMIT_NAMES if key != 'acceleration_max' and len(explicit[key])]
    if clash:
        raise LimitsError(f'{", ".join(clash)}: the URDF gives these limits, leave them empty')
    urdf = read_urdf(urdf_file) if urdf_file else parse_urdf(robot_description)
    if len(explicit['acceleration_max']):
        if len(explicit['acceleration_max']) != len(joint_names):
            raise LimitsError('acceleration_max needs joint_names, one name per value')
        acceleration = dict(zip(joint_names, explicit['acceleration_max']))
        source = f'{urdf.source} (acceleration_max from parameters)'
    else:
        robot = ScaraParams.from_yaml(robot_yaml)
        acceleration = dict(zip(robot.joint_names, robot.array('acceleration_max')))
        source = f'{urdf.source} (acceleration_max from {robot_yaml})'
        if not chosen and set(robot.joint_names) != set(urdf.names):
            acceleration = {}
    if partial:  # only joints the URDF does not have are refused (UrdfError)
        urdf.select([name for name in joint_names if name not in urdf.unlimited])
    limits = JointLimits.from_urdf(urdf, acceleration, required=() if partial else joint_names)
    return replace(limits, source=source)


def load_motion_limits(*, urdf_file: str = '', robot_description: str = '',
                       joint_names: Sequence[str] = (), robot_config: str = '',
                       acceleration_max: Sequence[float] = ()) -> JointLimits:
    """A URDF's limits of ``joint_names`` (all its limited joints when empty), with
    acceleration limits as the identifier takes them.

    The arguments are the identifier's parameters of the same names
    (:func:`load_joint_limits`); exactly one URDF.

    Raises
    ------
    LimitsError
        With one line saying what is missing: no URDF, a URDF that does not parse or has no
        limits for a joint (continuous, or no ``<limit>``), no acceleration limit.
    """
    if not urdf_file and not robot_description:
        raise LimitsError('no URDF: give urdf_file or robot_description (the arm\'s limits '
                          'come from its URDF)')
    try:
        limits = load_joint_limits(
            joint_names=list(joint_names), robot_config=robot_config, urdf_file=urdf_file,
            robot_description=robot_description,
            explicit={'acceleration_max': list(acceleration_max)})
        if joint_names:
            limits = limits.select(list(joint_names))
    except (UrdfError, LimitsError, ParamError, OSError) as exc:
        raise LimitsError(' '.join(str(exc).split())) from None
    if not limits.names:
        raise LimitsError(f'{limits.source}: no joint with position, velocity and '
                          'acceleration limits (URDF has no acceleration limits: give '
                          'joint_names and acceleration_max, or a robot_config naming the '
                          'joints)')
    return limits
