"""SCARA simulator core in pure numpy: excitation trajectories, controller, plant."""
from __future__ import annotations

from scara_ident_ros.sim.controller import ComputedTorqueController
from scara_ident_ros.sim.simulator import SimConfig, SimRecord, SimSample, Simulator
from scara_ident_ros.sim.trajectory import PRESETS, FourierTrajectory, make_trajectory

__all__ = ['FourierTrajectory', 'PRESETS', 'make_trajectory', 'ComputedTorqueController',
           'SimConfig', 'SimSample', 'SimRecord', 'Simulator']
