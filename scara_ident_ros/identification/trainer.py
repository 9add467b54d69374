"""How an online identifier learns from each sample: the paper's BP, or LM on a reservoir.

``'bp'`` (:class:`BackPropagation`)
    The paper's online training: one back-propagation step (with momentum) per sample, on
    that sample only. It tracks the latest motion closely, and forgets the earlier ones:
    frozen after a stream, such a network predicts a motion it has not just seen worse than
    the mean (README, "Results").
``'lm'`` (:class:`ReservoirLM`, the default)
    Every sample goes into a :class:`Reservoir`, a uniform random sample of the whole stream
    so far (``capacity`` samples); every ``interval`` samples the network takes one
    Levenberg–Marquardt step on the reservoir (the offline algorithm of Table 2, whose steps
    only lower the reservoir's error, so a step can never make the error explode). The
    network is fitted to all the motion seen, as offline training would fit it.
    Cost: one step costs about ``15 ms + 10 ms`` per 1000 reservoir samples on one core;
    with the defaults (4000 samples, a step every 200 samples at 1 kHz: 5 steps/s) about a
    quarter of a core on average.

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
        Samples between two LM steps.
    seed : int
        Seed of the reservoir's draws.
    """

    name = 'lm'

    def __init__(self, model: FeedForwardNet, *, capacity: int = 4000, interval: int = 200,
                 batch: int = 0, seed: int = 0) -> None:
        if interval < 1 or batch < 0:
            raise ValueError(f'need interval >= 1 and batch >= 0, got {interval}, {batch}')
        self.model = model
        self.interval = int(interval)
        self.batch = int(batch)
        self._rng = np.random.default_rng(seed + 2)
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
        """Take one LM step on the reservoir now; return whether the weights changed."""
        reservoir = self.reservoir
        if len(reservoir) < 2:
            return False
        model = self.model
        X, Y = reservoir.X, reservoir.Y
        if 0 < self.batch < len(reservoir):
            rows = self._rng.choice(len(reservoir), self.batch, replace=False)
            X, Y = X[rows], Y[rows]
        xs = model.x_scaling.transform(X)
        ys = model.y_scaling.transform(Y)
        if self._lm is None:
            self._lm = LevenbergMarquardt(model, xs, ys, mu=LM_MU)
        self._lm.set_data(xs, ys)
        try:
            self._lm.step()
        except StopTraining:  # no damping lowers the error: at a minimum of these samples
            self._lm.mu = LM_MU
            return False
        self.steps += 1
        return True


def make_trainer(name: str, model: FeedForwardNet, *, capacity: int = 4000,
                 interval: int = 200, batch: int = 0,
                 seed: int = 0) -> BackPropagation | ReservoirLM:
    """Build the trainer called ``name`` (one of :data:`TRAINERS`) for ``model``.

    ``capacity``, ``interval`` and ``seed`` are :class:`ReservoirLM`'s; BP uses the
    network's own learning rate and momentum.
    """
    if name == 'bp':
        return BackPropagation(model)
    if name == 'lm':
        return ReservoirLM(model, capacity=capacity, interval=interval, batch=batch, seed=seed)
    raise ValueError(f'unknown trainer {name!r}; choose from {TRAINERS}')
