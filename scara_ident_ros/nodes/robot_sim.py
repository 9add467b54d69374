"""``robot_sim``: any robot arm from its URDF, simulated, publishing ``/joint_states``.

The robot is ``robot:=ur5`` (an arm of the ``example-robot-data`` package: ur3, ur5, ur10,
panda, xarm7, z1), a ``urdf_file``, or a ``robot_description`` (the URDF text, as
``robot_state_publisher`` holds it). Its dynamics are Pinocchio's from the URDF's inertias,
plus per joint a rotor inertia and Stribeck (stick-slip) friction, with effort limits
(:class:`~scara_ident_ros.sim.pinocchio_robot.PinocchioRobot`); it tracks the same
excitations as ``scara_sim`` within the URDF's position, velocity and effort limits and the
acceleration limits under computed-torque + PD control. Topics, QoS, pacing, diagnostics
(hardware_id ``robot_sim``) and every other parameter are those of ``scara_sim``
(:mod:`scara_ident_ros.nodes.sim_node`); joint names on the wire are the URDF's. Every
per-joint parameter left empty takes its documented default.
"""
from __future__ import annotations

import sys
from dataclasses import replace
from typing import Any

import numpy as np

from scara_ident_ros.dynamics import ParamError
from scara_ident_ros.dynamics.urdf_limits import UrdfError
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.nodes.parameters import ParamSpec
from scara_ident_ros.nodes.runtime import run_node
from scara_ident_ros.nodes.sim_node import (SIM_PARAMETERS, SimulatorNode, desired_motion,
                                            fixed_at_start, sim_config)
from scara_ident_ros.sim import Simulator
from scara_ident_ros.sim.example_robots import (EXAMPLE_ROBOTS, ExampleRobotError,
                                                example_robot)
from scara_ident_ros.sim.joint_friction import JointFriction
from scara_ident_ros.sim.pinocchio_robot import FRICTION_DEFAULTS, PinocchioRobot

__all__ = ['RobotSimNode', 'main', 'PARAMETERS', 'SUBSTEPS']

#: RK4 steps per sample: 1 (1 ms at 1 kHz) where the SCARA takes 4. The arm's states stay
#: close to those of a much finer integration (docs/nodes.md, robot_sim), and each substep
#: costs four ABA calls: a 7-joint arm at 1 kHz then fits the CPU budget.
#: The friction's sticking band allows steps up to about 3 ms with the defaults (checked at
#: start, see PinocchioRobot.max_stable_step).
SUBSTEPS = 1

_PER_JOINT = 'one value per simulated joint; empty: '

PARAMETERS: tuple[ParamSpec, ...] = fixed_at_start((
    ParamSpec('robot', '', 'An arm of the example-robot-data package ('
              + ', '.join(EXAMPLE_ROBOTS) + '); empty: give urdf_file or robot_description'),
    ParamSpec('urdf_file', '', 'URDF file of the robot (instead of robot)'),
    ParamSpec('robot_description', '', 'URDF text of the robot (instead of robot), as '
              'robot_state_publisher has it'),
    ParamSpec('joints', [], 'Joints to simulate, in URDF order; the others are locked at the '
              "middle of their range; empty: the robot's arm joints (panda: panda_joint1..7, "
              'the fingers locked), or every revolute and prismatic joint of a URDF',
              items=str),
    ParamSpec('acceleration_max', [], 'Acceleration limit of the excitation, ' + _PER_JOINT
              + 'min(0.5 effort_max / largest inertia, 10/s x velocity_max)', 'rad/s²',
              items=float),
    ParamSpec('armature', [], 'Rotor inertia seen by each joint, ' + _PER_JOINT
              + "the URDF's, else 1e-3 s² x effort_max", 'kg·m²', items=float),
    ParamSpec('viscous', [], 'Viscous friction, ' + _PER_JOINT
              + f'{FRICTION_DEFAULTS["viscous"]:g} s x effort_max', 'N·m·s/rad', items=float),
    ParamSpec('coulomb', [], 'Coulomb (sliding) friction, ' + _PER_JOINT
              + f'{FRICTION_DEFAULTS["coulomb"]:g} x effort_max', 'N·m', items=float),
    ParamSpec('static_friction', [], 'Breakaway (static) friction, >= coulomb, '
              + _PER_JOINT + f'{FRICTION_DEFAULTS["static"]:g} x effort_max', 'N·m',
              items=float),
    ParamSpec('stribeck_velocity', [], 'Speed over which friction falls from static to '
              'Coulomb, ' + _PER_JOINT + f'{FRICTION_DEFAULTS["stribeck_velocity"]:g}',
              'rad/s', items=float),
    ParamSpec('stick_velocity', [], 'Velocity band of sticking (regularised static '
              'friction), ' + _PER_JOINT + f'{FRICTION_DEFAULTS["stick_velocity"]:g}',
              'rad/s', items=float),
    *(replace(spec, default=SUBSTEPS) if spec.name == 'substeps' else spec
      for spec in SIM_PARAMETERS),
))

_FRICTION_FIELDS = {'viscous': 'viscous', 'coulomb': 'coulomb', 'static_friction': 'static',
                    'stribeck_velocity': 'stribeck_velocity',
                    'stick_velocity': 'stick_velocity'}


def robot_from_settings(settings: dict[str, Any]) -> tuple[PinocchioRobot, str]:
    """The robot the parameters describe, and where its URDF came from.

    Raises
    ------
    ConfigError
        Unless exactly one of robot, urdf_file and robot_description is given, or for a
        bad URDF or per-joint value.
    """
    s = settings
    given = [name for name in ('robot', 'urdf_file', 'robot_description') if s[name]]
    if len(given) != 1:
        raise ConfigError(f'give exactly one of the parameters robot, urdf_file and '
                          f'robot_description, got {given or "none"}; robots: '
                          f'{", ".join(EXAMPLE_ROBOTS)}')
    joints = tuple(s['joints'])
    try:
        if s['robot']:
            entry = example_robot(s['robot'])
            urdf, what = entry.urdf, f'{s["robot"]} ({entry.urdf})'
            joints = joints or entry.joints
        else:
            urdf = s['urdf_file'] or s['robot_description']
            what = s['urdf_file'] or 'robot_description'
        robot = PinocchioRobot.from_urdf(urdf, joints=joints,
                                         armature=s['armature'] or None)
        n = robot.n_joints
        friction = None
        if any(s[name] for name in _FRICTION_FIELDS):
            defaults = robot.friction
            friction = JointFriction(**{
                field: _per_joint(s, name, n) or getattr(defaults, field)
                for name, field in _FRICTION_FIELDS.items()})
        robot = robot.replaced(friction=friction,
                               acceleration_max=_per_joint(s, 'acceleration_max', n) or None)
    except (ExampleRobotError, UrdfError, ParamError) as exc:
        raise ConfigError(str(exc)) from None
    return robot, what


def _per_joint(settings: dict[str, Any], name: str, n: int) -> tuple[float, ...]:
    """A per-joint list parameter as a tuple, empty if not given; n values otherwise."""
    values = tuple(float(v) for v in settings[name])
    if values and len(values) != n:
        raise ConfigError(f"parameter '{name}' must have {n} values (one per joint), "
                          f'got {len(values)}')
    return values


class RobotSimNode(SimulatorNode):
    """Publish a simulated URDF robot's joint states against absolute deadlines."""

    def __init__(self) -> None:
        super().__init__('robot_sim', PARAMETERS)

    def build(self, settings: dict[str, Any]) -> tuple[Simulator, tuple[str, ...], str]:
        """The URDF robot tracking the excitation; its joint names."""
        s = settings
        robot, what = robot_from_settings(s)
        config = sim_config(s, robot.n_joints)
        h = config.dt / config.substeps  # s
        if h > robot.max_stable_step():
            raise ConfigError(
                f'an RK4 step of {h:g} s is too long for the friction of {what} (at most '
                f'{robot.max_stable_step():.3g} s): raise substeps or rate_hz, or widen '
                'stick_velocity')
        try:
            trajectory = desired_motion(s, robot, robot.joint_names)
            simulator = Simulator(robot, trajectory, config)
        except ParamError as exc:
            raise ConfigError(str(exc)) from None
        self.get_logger().info(
            f'{robot.n_joints} joints {list(robot.joint_names)}, acceleration_max '
            f'{np.round(robot.acceleration_max, 2).tolist()} rad/s²')
        return simulator, robot.joint_names, what


def main(args: list[str] | None = None) -> None:
    """Console script ``robot_sim``."""
    sys.exit(run_node('robot_sim', RobotSimNode, args,
                      description=__doc__ or '', parameters=PARAMETERS))


if __name__ == '__main__':
    main()
