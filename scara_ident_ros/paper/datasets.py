"""The comparison's data sets: simulated runs of a robot, as records or network samples.

The simulator's record gives q'' either as the simulator's true acceleration
(``acceleration='true'``) or estimated from q' by the identifier's
:class:`~scara_ident_ros.identification.InputStage` (``'estimated'``); a recorded bag gives
the same samples through :mod:`scara_ident_ros.identification.recording`.
``Evaluations`` (name -> (X, Y)) is how the comparison's functions take the data sets to
evaluate on.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy.typing as npt

from scara_ident_ros.identification.dataset import ACCELERATIONS, Dataset, make_dataset
from scara_ident_ros.sim import SimConfig, SimRecord, Simulator, make_trajectory
from scara_ident_ros.sim.trajectory import Robot

__all__ = ['Evaluations', 'dataset_from_record', 'simulate_dataset', 'simulate_record']

#: Data sets to evaluate on: name -> (X (N, 3n), Y (N, n)), e.g. ``{'held-out': (X, Y)}``.
Evaluations = Mapping[str, tuple[npt.ArrayLike, npt.ArrayLike]]


def simulate_record(params: Robot, *, seconds: float, seed: int,
                    preset: str = 'standard', config: SimConfig | None = None) -> SimRecord:
    """Simulate the robot tracking a random excitation.

    ``seconds`` gives ``round(seconds / dt)`` samples; ``seed`` and ``preset`` choose the
    excitation (`make_trajectory`); ``config`` defaults to ``SimConfig()`` for the robot's
    joints (1 kHz, no noise, no disturbance).
    """
    cfg = SimConfig(n_joints=len(params.joint_names)) if config is None else config
    sim = Simulator(params, make_trajectory(preset, params, seed), cfg)
    return sim.simulate(max(0, round(seconds / cfg.dt)))


def simulate_dataset(params: Robot, *, seconds: float, seed: int,
                     preset: str = 'standard', acceleration: str = 'true',
                     config: SimConfig | None = None, name: str = '') -> Dataset:
    """`simulate_record` turned into a data set with true or estimated q''."""
    if acceleration not in ACCELERATIONS:
        raise ValueError(f'acceleration must be one of {ACCELERATIONS}, got {acceleration!r}')
    rec = simulate_record(params, seconds=seconds, seed=seed, preset=preset, config=config)
    return dataset_from_record(rec, acceleration=acceleration, name=name)


def dataset_from_record(record: SimRecord, *, acceleration: str = 'true',
                        name: str = '') -> Dataset:
    """A data set from a simulator record, with its true or an estimated q''."""
    return make_dataset(record.stamp_ns, record.q, record.qd, record.effort,
                        qdd=record.qdd if acceleration == 'true' else None, name=name)
