"""The ``lm`` online trainer: Levenberg–Marquardt steps on a uniform reservoir of the stream.

Every sample goes into a :class:`Reservoir`, a uniform random sample of the whole stream
so far (``reservoir_size`` samples); every ``lm_interval`` samples the network takes
``lm_steps``
Levenberg–Marquardt steps on the reservoir (the offline algorithm of Table 2, whose steps
only lower the reservoir's error, so a step can never make the error explode). The
network is fitted to all the motion seen, as offline training would fit it. JᵀJ is
assembled in float32 (``normal_equations(single=True)``, faster than float64 and
accurate enough for the step), the rest in float64, and the damped system is solved on
its blocks (``NormalBlocks.solve``). A step's cost grows with the joints and the
reservoir (benchmarks/lm_arms.md, benchmarks/bench_learning_curves.py).

The identifier's network for this trainer starts with friction steps
(``make_network(friction_steps=True)``, the node's ``lm_friction_steps``): without
them, joint 4, whose effort is mostly Coulomb friction (a step in q'4), stays
underfitted after 120 s (benchmarks/learning_curves.md).

Two options, off by default, were the earlier attempt at joint 4 on all-random weights
(benchmarks/bench_lm_variants.py): ``lm_float64`` assembles JᵀJ in float64, and
``lm_slow_share`` keeps that share of the reservoir for samples where some joint moves
slower than 1 % of its velocity input's half-range (:data:`SLOW_FRACTION`): the samples
around q' = 0, where the Coulomb step is, a small share of a stream.

:mod:`.trainer` builds it (``make_trainer('lm')``), in the caller's process or in a learner
process beside the stream (:mod:`.background_lm`, which keeps one of these).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.reservoir import RESERVOIR_SIZE, Reservoir
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.levenberg_marquardt import LevenbergMarquardt
from scara_ident_ros.nn.training import StopTraining

__all__ = ['LM_INTERVAL', 'LM_MU', 'LM_STEPS', 'RESERVOIR_SIZE', 'SLOW_FRACTION', 'ReservoirLM']

#: Defaults of the node's parameters of these names (``identification.parameters``; the
#: reservoir's size: :data:`~scara_ident_ros.identification.reservoir.RESERVOIR_SIZE`).
LM_INTERVAL = 200  # samples between two updates
LM_STEPS = 2  # Levenberg–Marquardt steps per update

LM_MU = 1e-3  # initial (and restart) damping of the reservoir LM
#: A sample is slow (``ReservoirLM``'s ``lm_slow_share``) when some joint's |q'| is below this
#: fraction of the half-range of the network's velocity input (of v_max with limit scaling).
SLOW_FRACTION = 0.01


class ReservoirLM:
    """Levenberg–Marquardt steps on a uniform reservoir of the stream (module docstring).

    Parameters
    ----------
    model : FeedForwardNet
        The network, with its scaling set (the robot's limits).
    reservoir_size : int
        Samples kept in the reservoir.
    lm_interval : int
        Samples between two updates.
    lm_steps : int
        LM steps per update, each on the whole reservoir.
    seed : int
        Seed of the reservoir's draws.
    lm_float64 : bool
        Assemble JᵀJ in float64 (more CPU) instead of float32.
    lm_slow_share : float
        Share of ``reservoir_size`` in [0, 0.5] kept for slow samples (some joint below
        :data:`SLOW_FRACTION` of its velocity input's half-range), in a reservoir of their
        own; 0: one uniform reservoir. The inputs are (q, q', q'') of n joints each.

    The parameters are the node's of the same names; ``lm_interval`` and ``lm_steps`` are
    attributes that may change between samples. ``steps_taken`` counts the LM steps.
    """

    name = 'lm'

    def __init__(self, model: FeedForwardNet, *, reservoir_size: int = RESERVOIR_SIZE,
                 lm_interval: int = LM_INTERVAL, lm_steps: int = LM_STEPS, seed: int = 0,
                 lm_float64: bool = False, lm_slow_share: float = 0.0) -> None:
        if lm_interval < 1 or lm_steps < 1:
            raise ValueError(f'need lm_interval >= 1 and lm_steps >= 1, got {lm_interval}, '
                             f'{lm_steps}')
        if not 0.0 <= lm_slow_share <= 0.5:
            raise ValueError(f'lm_slow_share must be in [0, 0.5], got {lm_slow_share}')
        self.model = model
        self.lm_interval = int(lm_interval)
        self.lm_steps = int(lm_steps)
        self.lm_float64 = bool(lm_float64)
        n_slow = round(reservoir_size * lm_slow_share)
        self.reservoir = Reservoir(reservoir_size - n_slow, model.n_inputs, model.n_outputs,
                                   seed=seed)
        self.slow: Reservoir | None = None
        if n_slow:
            self.slow = Reservoir(n_slow, model.n_inputs, model.n_outputs, seed=seed + 1)
            n = model.n_inputs // 3
            self._velocities = slice(n, 2 * n)
            scaling = model.x_scaling
            half = (scaling.hi[self._velocities] - scaling.lo[self._velocities]) / 2.0
            self._slow_below = SLOW_FRACTION * np.abs(half)  # (n,) physical speeds
        self.steps_taken = 0  # LM steps taken
        self._since = 0  # samples since the last step
        self._lm: LevenbergMarquardt | None = None

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Predict, keep the sample in the reservoir, and step every ``lm_interval`` samples."""
        predicted = self.model.predict(x)
        self.add(x, y)
        self._since += 1
        if self._since >= self.lm_interval:
            self._since = 0
            self.step()
        return predicted

    def add(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Offer one sample, x (3n,) and y (n,), to the reservoir (or to the slow one)."""
        if self.slow is not None and bool(
                np.any(np.abs(x[self._velocities]) < self._slow_below)):
            self.slow.add(x, y)
        else:
            self.reservoir.add(x, y)

    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The samples the LM steps fit: the reservoir's, then the slow ones, (m, ·)."""
        if self.slow is None or len(self.slow) == 0:
            return self.reservoir.X, self.reservoir.Y
        return (np.vstack([self.reservoir.X, self.slow.X]),
                np.vstack([self.reservoir.Y, self.slow.Y]))

    def step(self) -> bool:
        """Take ``lm_steps`` LM steps on the reservoir now; return whether the weights changed."""
        return self.step_on(*self.samples())

    def step_on(self, X: NDArray[np.float64], Y: NDArray[np.float64]) -> bool:
        """Take ``lm_steps`` LM steps on the samples X (m, 3n), Y (m, n) (physical units, e.g.
        a copy of :meth:`samples`); return whether the weights changed."""
        if len(X) < 2:
            return False
        model = self.model
        xs = model.x_scaling.transform(X)
        ys = model.y_scaling.transform(Y)
        if self._lm is None:
            self._lm = LevenbergMarquardt(model, xs, ys, mu=LM_MU, single=not self.lm_float64)
        self._lm.set_data(xs, ys)
        try:
            for _ in range(self.lm_steps):
                self._lm.step()
                self.steps_taken += 1
        except StopTraining:  # no damping lowers the error: at a minimum of these samples
            self._lm.mu = LM_MU
            return False
        return True
