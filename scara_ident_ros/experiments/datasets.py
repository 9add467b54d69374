"""Identification data sets: network inputs X = [q, q', q''] and efforts Y, with stamps.

A data set is plain arrays, whatever made them (the simulator here, a bag for
``scara-ident tables``)::

    stamp_ns : (N,) int64        sample times (ns)
    X        : (N, 3n) float64   [q_1..q_n, q'_1..q'_n, q''_1..q''_n] (rad, m, /s, /s²)
    Y        : (N, n) float64    joint efforts (N·m, N)

q'' is either the simulator's true acceleration (``acceleration='true'``) or estimated from q'
by the identifier's :class:`~scara_ident_ros.identification.InputStage` (by default zero-phase;
``acceleration='estimated'``; samples without an estimate are dropped).

``Evaluations`` (name -> (X, Y)) is how the experiment functions take the data sets to
evaluate on.

Public functions::

    make_dataset(stamp_ns, q, qd, effort, *, qdd=None, differentiator=None, name='')
        -> Dataset
    dataset_from_record(record, *, acceleration='true', name='') -> Dataset
    simulate_record(params, *, seconds, seed, preset='standard', config=None) -> SimRecord
    simulate_dataset(params, *, seconds, seed, preset='standard', acceleration='true',
                     config=None, name='') -> Dataset
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from scara_ident_ros.identification import AccelerationEstimate, InputStage, JointMap
from scara_ident_ros.sim import SimConfig, SimRecord, Simulator, make_trajectory
from scara_ident_ros.sim.trajectory import Robot

__all__ = ['ACCELERATIONS', 'Dataset', 'Evaluations', 'dataset_from_record',
           'make_dataset', 'simulate_dataset', 'simulate_record']

FloatArray = npt.NDArray[np.float64]

#: Where q'' comes from: the simulator's true acceleration, or estimated from q'.
ACCELERATIONS = ('true', 'estimated')

#: Data sets to evaluate on: name -> (X (N, 3n), Y (N, n)), e.g. ``{'held-out': (X, Y)}``.
Evaluations = Mapping[str, tuple[npt.ArrayLike, npt.ArrayLike]]


@dataclass(frozen=True)
class Dataset:
    """Samples for identification: inputs, efforts and their times.

    Attributes
    ----------
    stamp_ns : ndarray of shape (N,), int64
        Sample times (ns).
    X : ndarray of shape (N, 3n)
        Inputs [q, q', q''] of the n joints (rad or m, /s, /s²).
    Y : ndarray of shape (N, n)
        Joint efforts (N·m or N).
    acceleration : {'true', 'estimated'}
        Where the q'' columns come from.
    name : str
        Free label, e.g. ``'train'``.
    """

    stamp_ns: npt.NDArray[np.int64]
    X: FloatArray
    Y: FloatArray
    acceleration: str = 'true'
    name: str = field(default='')

    def __post_init__(self) -> None:
        n = self.Y.shape[1] if self.Y.ndim == 2 else -1
        if (self.X.ndim != 2 or n < 1 or self.X.shape != (self.Y.shape[0], 3 * n)
                or self.stamp_ns.shape != (self.Y.shape[0],)):
            raise ValueError(f'need stamp_ns (N,), X (N, 3n), Y (N, n); got '
                             f'{self.stamp_ns.shape}, {self.X.shape}, {self.Y.shape}')
        if self.acceleration not in ACCELERATIONS:
            raise ValueError(f'acceleration must be one of {ACCELERATIONS}, '
                             f'got {self.acceleration!r}')

    def __len__(self) -> int:
        return int(self.Y.shape[0])

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.Y.shape[1])

    @property
    def seconds(self) -> float:
        """Time spanned from the first to the last sample (s)."""
        return float(self.stamp_ns[-1] - self.stamp_ns[0]) * 1e-9 if len(self) else 0.0

    def take(self, index: slice | npt.ArrayLike, name: str | None = None) -> Dataset:
        """Return the samples at ``index`` (a slice, integer indices or a boolean mask)."""
        idx = index if isinstance(index, slice) else np.asarray(index)
        return Dataset(self.stamp_ns[idx], self.X[idx], self.Y[idx], self.acceleration,
                       self.name if name is None else name)

    def head(self, seconds: float, name: str | None = None) -> Dataset:
        """Return the samples stamped within ``seconds`` of the first one."""
        if not len(self):
            return self
        end = self.stamp_ns[0] + round(seconds * 1e9)
        return self.take(slice(0, int(np.searchsorted(self.stamp_ns, end))), name)

    def subsample(self, n_samples: int, *, seed: int = 0, name: str | None = None) -> Dataset:
        """Return ``n_samples`` samples drawn without replacement, in time order.

        Random rather than evenly spaced: an even step that divides the excitation's period
        would keep only a few distinct states of a periodic motion.

        Parameters
        ----------
        n_samples : int
            Samples to keep; all of them if ``n_samples >= len(self)``.
        seed : int
            Seed of the draw.
        """
        if n_samples >= len(self):
            return self if name is None else self.take(slice(None), name)
        rng = np.random.default_rng(seed)
        return self.take(np.sort(rng.choice(len(self), n_samples, replace=False)), name)


def make_dataset(stamp_ns: npt.ArrayLike, q: npt.ArrayLike, qd: npt.ArrayLike,
                 effort: npt.ArrayLike, *, qdd: npt.ArrayLike | None = None,
                 differentiator: AccelerationEstimate | None = None, name: str = '') -> Dataset:
    """Build a data set from joint states.

    Parameters
    ----------
    stamp_ns : array_like of shape (N,)
        Sample times (ns).
    q, qd, effort : array_like of shape (N, n)
        Positions (rad, m), velocities (rad/s, m/s) and efforts (N·m, N).
    qdd : array_like of shape (N, n), optional
        True accelerations; if None, the samples go through the identifier's
        :class:`InputStage` (q'' estimated, samples without an estimate dropped).
    differentiator : Differentiator or CentredDifferentiator, optional
        The stage's estimate when ``qdd`` is None (default: the identifier's).
    name : str
        Label of the data set.
    """
    stamps = np.asarray(stamp_ns, dtype=np.int64)
    q = np.asarray(q, dtype=np.float64)
    qd = np.asarray(qd, dtype=np.float64)
    effort = np.asarray(effort, dtype=np.float64)
    if qdd is not None:
        X = np.hstack([q, qd, np.asarray(qdd, dtype=np.float64)])
        return Dataset(stamps, X, effort, 'true', name)
    n = effort.shape[1]
    names = tuple(f'joint{j + 1}' for j in range(n))
    stage = InputStage(JointMap(names, n_joints=n), differentiator=differentiator)
    kept, X, Y = stage.batch(stamps, names, q, qd, effort)
    return Dataset(kept, X, Y, 'estimated', name)


def simulate_record(params: Robot, *, seconds: float, seed: int,
                    preset: str = 'standard', config: SimConfig | None = None) -> SimRecord:
    """Simulate the robot tracking a random excitation.

    Parameters
    ----------
    params : ScaraParams or PinocchioRobot
        The robot.
    seconds : float
        Duration (s); ``round(seconds / dt)`` samples.
    seed : int
        Seed of the excitation (`make_trajectory`); another seed is another excitation.
    preset : str
        Excitation preset of :data:`scara_ident_ros.sim.PRESETS`.
    config : SimConfig, optional
        Simulation settings; default ``SimConfig()`` for the robot's joints (1 kHz, no
        noise, no disturbance).
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
