"""The limits an excitation on a real arm keeps to: the robot's, less the safety margins.

A real robot's position, velocity and acceleration limits come from its URDF (file or
``robot_description``) with acceleration limits as the identifier takes them
(``acceleration_max`` per joint name, or the robot YAML's; see
:func:`~scara_ident_ros.dynamics.joint_limits.load_joint_limits`). The excitation keeps
``position_margin`` of each joint's range clear at both ends and moves at most
``velocity_scale`` and ``acceleration_scale`` of the velocity and acceleration limits:
:meth:`MotionLimits.with_margins`. :meth:`MotionLimits.violations` checks sampled motion
against them, sample by sample.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.errors import ScaraIdentError

__all__ = ['MotionLimits', 'MotionLimitsError', 'load_motion_limits']

#: Relative tolerance of :meth:`MotionLimits.violations` (rounding of sampled values).
TOLERANCE = 1e-9


class MotionLimitsError(ScaraIdentError, ValueError):
    """Limits that are missing or unusable, or settings of the margins out of range."""


@dataclass(frozen=True)
class MotionLimits:
    """Position range, velocity and acceleration limits of n joints.

    Attributes
    ----------
    names : tuple of str of length n
        The joints, in the order of the arrays.
    position_min, position_max : ndarray of shape (n,)
        Position range (rad or m), ``position_min < position_max``.
    velocity_max, acceleration_max : ndarray of shape (n,)
        Symmetric limits of |q'| (rad/s, m/s) and |q''| (rad/s², m/s²), > 0.
    source : str
        Where the limits come from, for messages.
    """

    names: tuple[str, ...]
    position_min: NDArray[np.float64]
    position_max: NDArray[np.float64]
    velocity_max: NDArray[np.float64]
    acceleration_max: NDArray[np.float64]
    source: str = ''

    def __post_init__(self) -> None:
        n = len(self.names)
        for key in ('position_min', 'position_max', 'velocity_max', 'acceleration_max'):
            value = np.array(getattr(self, key), dtype=float)
            if value.shape != (n,) or not np.all(np.isfinite(value)):
                raise MotionLimitsError(f'{key} must be {n} finite values, got {value!r}')
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        if n == 0 or len(set(self.names)) != n:
            raise MotionLimitsError(f'need one or more distinct joint names, got {self.names}')
        if np.any(self.position_min >= self.position_max):
            raise MotionLimitsError(f'{self.source}: position_min must be below position_max')
        if np.any(self.velocity_max <= 0) or np.any(self.acceleration_max <= 0):
            raise MotionLimitsError(f'{self.source}: velocity and acceleration limits must be '
                                    '> 0')

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return len(self.names)

    @property
    def centre(self) -> NDArray[np.float64]:
        """Middle of each joint's range, shape (n,) (rad or m)."""
        return 0.5 * (self.position_min + self.position_max)

    def with_margins(self, position_margin: float, velocity_scale: float,
                     acceleration_scale: float) -> MotionLimits:
        """These limits less ``position_margin`` (in [0, 0.5)) of each range at each end and
        scaled by ``velocity_scale`` and ``acceleration_scale`` (in (0, 1])."""
        if not 0.0 <= position_margin < 0.5:
            raise MotionLimitsError(f'position_margin must be in [0, 0.5), got '
                                    f'{position_margin!r}')
        for name, value in (('velocity_scale', velocity_scale),
                            ('acceleration_scale', acceleration_scale)):
            if not 0.0 < value <= 1.0:
                raise MotionLimitsError(f'{name} must be in (0, 1], got {value!r}')
        clear = position_margin * (self.position_max - self.position_min)
        return MotionLimits(self.names, self.position_min + clear, self.position_max - clear,
                            velocity_scale * self.velocity_max,
                            acceleration_scale * self.acceleration_max,
                            f'{self.source} with margins')

    def outside(self, q: NDArray[np.float64]) -> list[str]:
        """The joints whose position in ``q`` (n,) is outside the range, as text."""
        return [f'{name} = {value:g} not in [{low:g}, {high:g}]' for name, value, low, high
                in zip(self.names, q, self.position_min, self.position_max)
                if not low <= value <= high]

    def violations(self, q: NDArray[np.float64], qd: NDArray[np.float64],
                   qdd: NDArray[np.float64], *,
                   position_hull: NDArray[np.float64] | None = None) -> list[str]:
        """What sampled motion breaks of these limits, one text per kind and joint.

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


def load_motion_limits(*, urdf_file: str = '', robot_description: str = '',
                       joint_names: Sequence[str] = (), robot_config: str = '',
                       acceleration_max: Sequence[float] = ()) -> MotionLimits:
    """A URDF's limits of ``joint_names`` (all its limited joints when empty), with
    acceleration limits as the identifier takes them.

    The arguments are the identifier's parameters of the same names
    (:func:`~scara_ident_ros.dynamics.joint_limits.load_joint_limits`); exactly one URDF.

    Raises
    ------
    MotionLimitsError
        With one line saying what is missing: no URDF, a URDF that does not parse or has no
        limits for a joint (continuous, or no ``<limit>``), no acceleration limit.
    """
    # imported here: the joint limits pull in the networks (their scaling), which a dry run
    # of the excitation does not need until it loads the limits
    from scara_ident_ros.dynamics.joint_limits import LimitsError, load_joint_limits
    from scara_ident_ros.dynamics.params import ParamError
    from scara_ident_ros.dynamics.urdf_limits import UrdfError

    if not urdf_file and not robot_description:
        raise MotionLimitsError('no URDF: give urdf_file or robot_description (the arm\'s '
                                'limits come from its URDF)')
    try:
        limits = load_joint_limits(
            joint_names=list(joint_names), robot_config=robot_config, urdf_file=urdf_file,
            robot_description=robot_description,
            explicit={'acceleration_max': list(acceleration_max)})
        if joint_names:
            limits = limits.select(list(joint_names))
    except (UrdfError, LimitsError, ParamError, OSError) as exc:
        raise MotionLimitsError(' '.join(str(exc).split())) from None
    if not limits.names:
        raise MotionLimitsError(f'{limits.source}: no joint with position, velocity and '
                                'acceleration limits (URDF has no acceleration limits: give '
                                'joint_names and acceleration_max, or a robot_config naming '
                                'the joints)')
    return MotionLimits(limits.names, limits.position_min, limits.position_max,
                        limits.velocity_max, limits.acceleration_max, limits.source)
