"""How an online identifier learns from each sample: the paper's BP, or LM on a reservoir.

``'bp'`` (:class:`BackPropagation`)
    The paper's online training: one back-propagation step (with momentum) per sample, on
    that sample only. It tracks the latest motion closely, and forgets the earlier ones:
    frozen after a stream, such a network predicts a motion it has not just seen worse than
    the mean (README, "Results").
``'lm'`` (:class:`ReservoirLM`, the default)
    Every sample goes into a :class:`Reservoir`, a uniform random sample of the whole stream
    so far (``capacity`` samples); every ``interval`` samples the network takes ``steps``
    Levenberg–Marquardt steps on the reservoir (the offline algorithm of Table 2, whose steps
    only lower the reservoir's error, so a step can never make the error explode). The
    network is fitted to all the motion seen, as offline training would fit it. JᵀJ is
    assembled in float32 (``normal_equations(single=True)``: 22 ms instead of 36 ms for 4000
    samples), the rest in float64.
    Cost (``benchmarks/bench_learning_curves.py`` reports it): with the defaults (4000
    samples, 2 steps every 200 samples: 10 steps/s at 1 kHz) about 0.3–0.4 of a core.
    Measured (FFS, ``sequence`` stream): frozen after 120 s, held-out NMSE ≤ 1e-3 on every
    joint; 1 step per 200 samples reaches that only after about 150 s, 1 step per 400
    samples not within 120 s.

Both give the a-priori prediction of each sample, made before the sample is learnt.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.levenberg_marquardt import LevenbergMarquardt
from scara_ident_ros.nn.training import StopTraining

if TYPE_CHECKING:
    from scara_ident_ros.identification.online_identifier import EffortModel

__all__ = ['Trainer', 'BackPropagation', 'ReservoirLM', 'TRAINERS', 'make_trainer']

#: Names of the online trainers; ``'lm'`` is the default.
TRAINERS = ('lm', 'bp')

LM_MU = 1e-3  # initial (and restart) damping of the reservoir LM


class Trainer(Protocol):
    """Predict a sample a priori, then learn from it."""

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the prediction of ``y`` (n,) from ``x`` (3n,) made before learning it.

        Raises
        ------
        ValueError
            If the model refused the step (it would not be finite); nothing was learnt.
        """
        ...


class BackPropagation:
    """The paper's online BP: one ``partial_fit`` step per sample.

    Parameters
    ----------
    model : EffortModel
        The network, with its scaling set; learning rate and momentum are its own.
    """

    name = 'bp'

    def __init__(self, model: EffortModel) -> None:
        self.model = model

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """One BP step; the a-priori prediction comes from the step's forward pass."""
        return y - self.model.partial_fit(x[np.newaxis], y[np.newaxis])[0]


class ReservoirLM:
    """Levenberg–Marquardt steps on a uniform reservoir of the stream (module docstring).

    Parameters
    ----------
    model : FeedForwardNet
        The network, with its scaling set (the robot's limits).
    capacity : int
        Samples kept in the reservoir.
    interval : int
        Samples between two updates.
    steps : int
        LM steps per update, each on the whole reservoir.
    seed : int
        Seed of the reservoir's draws.
    """

    name = 'lm'

    def __init__(self, model: FeedForwardNet, *, capacity: int = 4000, interval: int = 200,
                 steps: int = 2, seed: int = 0) -> None:
        if interval < 1 or steps < 1:
            raise ValueError(f'need interval >= 1 and steps >= 1, got {interval}, {steps}')
        self.model = model
        self.interval = int(interval)
        self.steps_per_update = int(steps)
        self.reservoir = Reservoir(capacity, model.n_inputs, model.n_outputs, seed=seed)
        self.steps = 0  # LM steps taken
        self._since = 0  # samples since the last step
        self._lm: LevenbergMarquardt | None = None

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Predict, keep the sample in the reservoir, and step every ``interval`` samples."""
        predicted = self.model.predict(x)
        self.reservoir.add(x, y)
        self._since += 1
        if self._since >= self.interval:
            self._since = 0
            self.step()
        return predicted

    def step(self) -> bool:
        """Take ``steps`` LM steps on the reservoir now; return whether the weights changed."""
        reservoir = self.reservoir
        if len(reservoir) < 2:
            return False
        model = self.model
        xs = model.x_scaling.transform(reservoir.X)
        ys = model.y_scaling.transform(reservoir.Y)
        if self._lm is None:
            self._lm = LevenbergMarquardt(model, xs, ys, mu=LM_MU, single=True)
        self._lm.set_data(xs, ys)
        try:
            for _ in range(self.steps_per_update):
                self._lm.step()
                self.steps += 1
        except StopTraining:  # no damping lowers the error: at a minimum of these samples
            self._lm.mu = LM_MU
            return False
        return True


def make_trainer(name: str, model: FeedForwardNet, *, capacity: int = 4000,
                 interval: int = 200, steps: int = 2,
                 seed: int = 0) -> BackPropagation | ReservoirLM:
    """Build the trainer called ``name`` (one of :data:`TRAINERS`) for ``model``.

    ``capacity``, ``interval``, ``steps`` and ``seed`` are :class:`ReservoirLM`'s; BP uses
    the network's own learning rate and momentum.
    """
    if name == 'bp':
        return BackPropagation(model)
    if name == 'lm':
        return ReservoirLM(model, capacity=capacity, interval=interval, steps=steps,
                           seed=seed)
    raise ValueError(f'unknown trainer {name!r}; choose from {TRAINERS}')
