"""The limits an excitation on a real arm keeps to: the robot's, less the safety margins.

A real robot's position, velocity and acceleration limits come from its URDF (file or
``robot_description``) with acceleration limits as the identifier takes them
(``acceleration_max`` per joint name, or the robot YAML's): :func:`load_motion_limits` is
:func:`~scara_ident_ros.dynamics.joint_limits.load_joint_limits` with a URDF required and
every error in one line. The excitation keeps ``position_margin`` of each joint's range
clear at both ends and moves at most ``velocity_scale`` and ``acceleration_scale`` of the
velocity and acceleration limits
(:meth:`~scara_ident_ros.dynamics.joint_limits.JointLimits.with_margins`), and checks its
samples against them (:meth:`~scara_ident_ros.dynamics.joint_limits.JointLimits.violations`).
"""
from __future__ import annotations

from collections.abc import Sequence

from scara_ident_ros.dynamics.joint_limits import JointLimits, LimitsError, load_joint_limits
from scara_ident_ros.dynamics.params import ParamError
from scara_ident_ros.dynamics.urdf_limits import UrdfError

__all__ = ['load_motion_limits']


def load_motion_limits(*, urdf_file: str = '', robot_description: str = '',
                       joint_names: Sequence[str] = (), robot_config: str = '',
                       acceleration_max: Sequence[float] = ()) -> JointLimits:
    """A URDF's limits of ``joint_names`` (all its limited joints when empty), with
    acceleration limits as the identifier takes them.

    The arguments are the identifier's parameters of the same names
    (:func:`~scara_ident_ros.dynamics.joint_limits.load_joint_limits`); exactly one URDF.

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
