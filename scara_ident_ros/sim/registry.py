"""Excitation trajectories by name: the presets of `trajectory.PRESETS` and the sequence.

The names are what the simulator nodes' ``trajectory`` parameter and the CLI accept.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from scara_ident_ros.sim.sequence import SEQUENCE_EXCITATION, SequenceTrajectory
from scara_ident_ros.sim.trajectory import PRESETS, FourierTrajectory, Robot

__all__ = ['SEQUENCE', 'TRAJECTORIES', 'make_trajectory']

#: Name of the endless sequence of random ``'standard'``-like excitations joined smoothly
#: (:class:`scara_ident_ros.sim.sequence.SequenceTrajectory`): persistent excitation.
SEQUENCE = 'sequence'

#: Every name :func:`make_trajectory` accepts: the presets, then :data:`SEQUENCE`.
TRAJECTORIES: tuple[str, ...] = (*PRESETS, SEQUENCE)


def make_trajectory(preset: str, params: Robot, seed: int,
                    **overrides: Any) -> FourierTrajectory | SequenceTrajectory:
    """Build a random excitation by name: a preset of :data:`PRESETS` or :data:`SEQUENCE`.

    ``overrides`` replace settings of the preset, or of each excitation of the sequence
    (keywords of :meth:`FourierTrajectory.random`).

    Raises
    ------
    ValueError
        If the name is unknown; the message lists the known names.
    """
    if not isinstance(preset, str) or preset not in TRAJECTORIES:
        raise ValueError(f'unknown trajectory {preset!r}; known trajectories are '
                         f'{", ".join(sorted(TRAJECTORIES))}')
    if preset == SEQUENCE:
        return SequenceTrajectory(params, seed=seed,
                                  excitation={**SEQUENCE_EXCITATION, **overrides})
    settings: Mapping[str, Any] = {**PRESETS[preset], **overrides}
    return FourierTrajectory.random(params, seed=seed, **settings)
