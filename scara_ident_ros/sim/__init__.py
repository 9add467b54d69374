"""Simulator core in pure numpy: excitation trajectories (one periodic excitation or an
endless sequence of them), controller, plant, for the SCARA or, with
:mod:`scara_ident_ros.sim.pinocchio_robot` (imported on its own: it loads Pinocchio), any
URDF arm."""
from __future__ import annotations

from scara_ident_ros.sim.controller import ComputedTorqueController
from scara_ident_ros.sim.jitter import StampJitter
from scara_ident_ros.sim.simulator import SimConfig, SimRecord, SimSample, Simulator
from scara_ident_ros.sim.sequence import SequenceTrajectory
from scara_ident_ros.sim.registry import SEQUENCE, TRAJECTORIES, make_trajectory
from scara_ident_ros.sim.trajectory import PRESETS, FourierTrajectory

__all__ = ['FourierTrajectory', 'SequenceTrajectory', 'PRESETS', 'SEQUENCE', 'TRAJECTORIES',
           'make_trajectory', 'ComputedTorqueController', 'SimConfig', 'SimSample', 'SimRecord',
           'Simulator', 'StampJitter']
