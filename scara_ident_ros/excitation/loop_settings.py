"""The ``excitation`` node's settings that shape the motion, with the node's defaults.

The node declares its parameters with these defaults, ``scara-ident excitation --dry-run``
takes its options' defaults from them, and the simulated loop
(:func:`~scara_ident_ros.excitation.simulated_loop.simulate_loop`) runs with them: the one
place they are written (``config/excitation.yaml`` repeats them, checked by the tests).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ['LoopSettings']


@dataclass(frozen=True)
class LoopSettings:
    """The ``excitation`` node's parameters that shape the motion; defaults the node's.

    Attributes
    ----------
    position_margin : float
        Fraction of each joint's range kept clear at both ends.
    velocity_scale, acceleration_scale : float
        Fractions of the velocity and acceleration limits the motion keeps to.
    seed : int
        Seed of the sequence excitation.
    point_period, chunk_period, horizon, start_delay : float
        Time between two points of a chunk, between two chunks, from a chunk's send time
        to its stop, and from the first chunk to the plan's origin (s).
    """

    position_margin: float = 0.1
    velocity_scale: float = 0.5
    acceleration_scale: float = 0.5
    seed: int = 0
    point_period: float = 0.01
    chunk_period: float = 0.25
    horizon: float = 1.0
    start_delay: float = 0.5
