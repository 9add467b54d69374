"""Persistent excitation of a real arm through a trajectory controller, planned in numpy.

:func:`load_motion_limits` (a URDF's limits as the identifier takes them, which the
excitation keeps to less the safety margins), :class:`JointSequence` (the simulator's
sequence for any joints), :class:`ExcitationPlan` (approach, then sequence),
:func:`plan_stop` (to rest along the path), :func:`make_chunk` (what is sent),
:class:`LoopSettings` (the node's motion settings, with their defaults). No rclpy: the
``excitation`` node and ``scara-ident excitation --dry-run`` share this core.
:func:`~scara_ident_ros.excitation.simulated_loop.simulate_loop` runs the whole loop with a
simulated arm in one process, for benchmarks.
"""
from __future__ import annotations

from scara_ident_ros.dynamics.joint_limits import load_motion_limits
from scara_ident_ros.excitation.chunks import Chunk, make_chunk
from scara_ident_ros.excitation.joint_sequence import JointSequence
from scara_ident_ros.excitation.plan import ExcitationPlan
from scara_ident_ros.excitation.simulated_loop import LoopSettings
from scara_ident_ros.excitation.stopping import Stop, plan_stop

__all__ = ['Chunk', 'ExcitationPlan', 'JointSequence', 'LoopSettings', 'Stop',
           'load_motion_limits', 'make_chunk', 'plan_stop']
