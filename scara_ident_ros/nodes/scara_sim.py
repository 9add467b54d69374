"""``scara_sim``: the simulated SCARA, publishing ``/joint_states`` in real time.

The physics (Lagrangian model, excitation, computed-torque controller, RK4) live in
:mod:`scara_ident_ros.sim`; this node only paces the simulator against absolute
deadlines and converts each sample to a ``sensor_msgs/JointState``:
``position`` (rad, m), ``velocity`` (rad/s, m/s) and ``effort`` (N·m, N) = the
torque/force actually applied, ``header.stamp`` = simulated time. Once a second it
reports on ``/diagnostics`` (hardware_id ``scara_sim``) its rate and its late samples
(:func:`~scara_ident_ros.nodes.health.simulator_health`). All but the robot's
parameters, and the node's body, are shared with ``robot_sim``
(:mod:`scara_ident_ros.nodes.sim_node`).
"""
from __future__ import annotations

import sys
from typing import Any

from scara_ident_ros.dynamics import ParamError, ScaraParams
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.nodes.parameters import ParamSpec
from scara_ident_ros.nodes.runtime import run_node
from scara_ident_ros.nodes.sim_node import (HISTORY, SIM_PARAMETERS, SimulatorNode,
                                            desired_motion, fixed_at_start, history_depth,
                                            sim_config)
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import Simulator

__all__ = ['ScaraSimNode', 'main', 'history_depth', 'HISTORY']

PARAMETERS: tuple[ParamSpec, ...] = fixed_at_start((
    ParamSpec('robot_config', '', 'YAML file of the robot parameters; empty: the installed '
              'config/scara.yaml'),
    ParamSpec('joint_names', [], 'Joint names on the wire, in the order joint1..joint4; '
              'empty: the joint_names of the robot file', items=str),
    *SIM_PARAMETERS,
))


class ScaraSimNode(SimulatorNode):
    """Publish the simulated SCARA's joint states against absolute deadlines."""

    def __init__(self) -> None:
        super().__init__('scara_sim', PARAMETERS)

    def build(self, settings: dict[str, Any]) -> tuple[Simulator, tuple[str, ...], str]:
        """The SCARA of ``robot_config`` tracking the excitation; its joint names."""
        s = settings
        try:
            path = s['robot_config'] or str(config_path('scara.yaml'))
            params = ScaraParams.from_yaml(path)
            names = tuple(s['joint_names']) or params.joint_names
            if len(names) != 4 or len(set(names)) != 4:
                raise ConfigError(f"parameter 'joint_names' must be 4 distinct names, "
                                  f'got {list(names)}')
            trajectory = desired_motion(s, params, names)
            simulator = Simulator(params, trajectory, sim_config(s, 4))
        except (ParamError, OSError) as exc:
            raise ConfigError(str(exc)) from None
        return simulator, names, path


def main(args: list[str] | None = None) -> None:
    """Console script ``scara_sim``."""
    sys.exit(run_node('scara_sim', ScaraSimNode, args,
                      description=__doc__ or '', parameters=PARAMETERS))


if __name__ == '__main__':
    main()
