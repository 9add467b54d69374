"""The topic names of the identification graph, in one place (no rclpy).

The nodes name ``joint_states``, ``identified_torque`` and ``identification_mse``
relative to their namespace: ``scara-ident run`` and the launch file start identifier
``M`` under ``/M`` with ``joint_states`` remapped to ``/joint_states``, so a run's bag holds
``/joint_states``, ``/M/identified_torque`` and ``/M/identification_mse``.
"""
from __future__ import annotations

__all__ = ['CLOCK', 'CONTACT', 'DIAGNOSTICS', 'EXTERNAL_EFFORT', 'EXTERNAL_TORQUE',
           'IDENTIFIER_OUTPUTS', 'JOINT_STATES', 'JOINT_TRAJECTORY', 'MSE', 'TORQUE',
           'in_namespace', 'mse_topic', 'torque_topic']

JOINT_STATES = 'joint_states'  # sensor_msgs/JointState: q, q', effort of the robot
TORQUE = 'identified_torque'  # sensor_msgs/JointState: an identifier's a-priori predictions
MSE = 'identification_mse'  # std_msgs/Float64MultiArray: its errors (mse_layout)
EXTERNAL_TORQUE = 'external_torque'  # sensor_msgs/JointState: measured − predicted effort
CONTACT = 'contact'  # sensor_msgs/JointState: the joints over their contact threshold
#: What a run records of each identifier. external_torque is left out (as many messages as
#: identified_torque, and measured − predicted of two recorded topics), and so is contact
#: (the same residual over thresholds that diagnostics report).
IDENTIFIER_OUTPUTS = (TORQUE, MSE)
EXTERNAL_EFFORT = '~/external_effort'  # sensor_msgs/JointState: a simulator's applied contact
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'
#: trajectory_msgs/JointTrajectory: commands of ros2_control's joint_trajectory_controller
#: (the controller's default name), sent by ``excitation``, followed by ``scara_sim``
JOINT_TRAJECTORY = '/joint_trajectory_controller/joint_trajectory'


def in_namespace(name: str, namespace: str = '') -> str:
    """``name`` made absolute in ``namespace``: ``in_namespace(TORQUE, 'ffs')`` is
    ``'/ffs/identified_torque'``, ``in_namespace(JOINT_STATES)`` is ``'/joint_states'``."""
    return f'/{namespace}/{name}' if namespace else f'/{name}'


def torque_topic(method: str) -> str:
    """The topic of ``method``'s a-priori predictions in a run."""
    return in_namespace(TORQUE, method)


def mse_topic(method: str) -> str:
    """The topic of ``method``'s windowed errors in a run."""
    return in_namespace(MSE, method)
