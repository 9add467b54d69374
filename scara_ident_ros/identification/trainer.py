"""How an online identifier learns from each sample: the paper's BP, or LM on a reservoir.

``'bp'`` (:class:`BackPropagation`)
    The paper's online training: one back-propagation step (with momentum) per sample, on
    that sample only. It tracks the latest motion closely, and forgets the earlier ones:
    frozen after a stream, such a network predicts a motion it has not just seen worse than
    the mean (docs/results.md). A guard keeps a too large learning rate or an odd sample
    from making the error explode: a step after which the error on its own sample is more
    than ten times larger than before it and than the typical error of the last ~100
    samples (``GROWTH`` in squares, above a floor) is undone with the momentum, the sample
    counted as refused, and the learning rate halved for good (a rate that overshoots is too
    large for this robot). At the paper's learning rate the guard does not act; how it
    holds a too large one: docs/results.md, "The learning guard". The identifier clips
    predictions beyond the effort limits.

``'lm'`` (:class:`~.reservoir_lm.ReservoirLM`, the default)
    Levenberg–Marquardt steps on a uniform reservoir of the whole stream so far: the network
    is fitted to all the motion seen, as offline training would fit it, and a step can never
    make the error explode (:mod:`.reservoir_lm`). With ``background``, the reservoir and its
    steps live in a learner process beside the stream (:mod:`.background_lm`).

Both give the a-priori prediction of each sample, made before the sample is learnt.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.background_lm import BackgroundLM
from scara_ident_ros.identification.learner_settings import NICE, LearnerSettings
from scara_ident_ros.identification.reservoir_lm import (LM_INTERVAL, LM_STEPS, RESERVOIR_SIZE,
                                                         ReservoirLM)
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.scaling import MinMaxScaling

if TYPE_CHECKING:
    from scara_ident_ros.learners.hybrid_model import HybridModel

__all__ = ['Trainer', 'BackPropagation', 'TRAINERS', 'make_trainer',
           'starts_with_friction_steps']

#: Names of the online trainers; ``'lm'`` is the default.
TRAINERS = ('lm', 'bp')

#: BP's step guard: a step is undone if, on its own sample, the squared scaled error after
#: it exceeds GROWTH times the one before it plus GUARD_FLOOR per output (scaled units: the
#: outputs' range is [-1, 1], so the floor is an error of 5 % of an effort range).
GROWTH = 100.0
GUARD_FLOOR = 2.5e-3
TYPICAL_WEIGHT = 0.01  # of the newest sample in the guard's typical error (~100 samples)


class Trainer(Protocol):
    """Predict a sample a priori, then learn from it."""

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the prediction of ``y`` (n,) from ``x`` (3n,) made before learning it.

        Raises
        ------
        ValueError
            If the step was refused (it would not be finite, or it would make the error
            explode); nothing was learnt.
        """
        ...


@runtime_checkable
class SteppedModel(Protocol):
    """What :class:`BackPropagation` needs of a network: steps, and its weights to undo one."""

    def predict(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Efforts (n,) of one input (3n,) (see ``estimator.OnlineEstimator``)."""
        ...

    def partial_fit(self, X: NDArray[np.float64],
                    Y: NDArray[np.float64]) -> NDArray[np.float64]:
        """One step per row; the a-priori errors (see ``estimator.OnlineEstimator``)."""
        ...

    @property
    def y_scaling(self) -> MinMaxScaling:
        """The outputs' scaling (errors are compared in scaled units)."""
        ...

    def get_theta(self) -> NDArray[np.float64]:
        """A copy of the weights, shape (n_params,)."""
        ...

    def set_theta(self, theta: NDArray[np.float64]) -> None:
        """Copy weights of shape (n_params,) in."""
        ...

    def reset_momentum(self) -> None:
        """Forget the momentum of the per-sample steps."""
        ...

    @property
    def learning_rate(self) -> float:
        """The per-sample step's learning rate."""
        ...

    @learning_rate.setter
    def learning_rate(self, value: float) -> None:
        ...


class BackPropagation:
    """The paper's online BP: one ``partial_fit`` step per sample, with a guard.

    Parameters
    ----------
    model : SteppedModel or OnlineEstimator
        The network, with its scaling set; learning rate and momentum are its own. The
        guard needs a :class:`SteppedModel`; another effort model is stepped unguarded.

    Attributes
    ----------
    undone : int
        Steps undone by the guard (module docstring).
    """

    name = 'bp'

    def __init__(self, model: Any) -> None:
        self.model = model
        self.undone = 0
        self.guarded = isinstance(model, SteppedModel)
        self._typical = 0.0  # moving average of the a-priori squared scaled error

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """One BP step; the a-priori prediction comes from the step's forward pass.

        Raises
        ------
        ValueError
            If the step was not finite (the weights are then as before it), or overshot
            (module docstring: the weights are then as before it, the momentum forgotten
            and the learning rate halved).
        """
        model = self.model
        if not self.guarded:
            return y - model.partial_fit(x[np.newaxis], y[np.newaxis])[0]
        before = model.get_theta()
        prior = model.partial_fit(x[np.newaxis], y[np.newaxis])[0]
        gain = model.y_scaling.gain
        post = (y - model.predict(x)) * gain
        prior_scaled = prior * gain
        prior_sq = float(prior_scaled @ prior_scaled)
        self._typical += TYPICAL_WEIGHT * (prior_sq - self._typical)
        limit = GROWTH * max(prior_sq, self._typical) + GUARD_FLOOR * y.shape[0]
        if not float(post @ post) <= limit:
            model.set_theta(before)
            model.reset_momentum()
            model.learning_rate = model.learning_rate / 2.0
            self.undone += 1
            raise ValueError('the step overshot: the error on its own sample grew from '
                             f'{prior_sq:.3g} to '
                             f'{float(post @ post):.3g} (scaled); undone, learning rate '
                             f'now {model.learning_rate:.3g}')
        return y - prior


def make_trainer(name: str, model: FeedForwardNet, *, reservoir_size: int = RESERVOIR_SIZE,
                 lm_interval: int = LM_INTERVAL, lm_steps: int = LM_STEPS, seed: int = 0,
                 lm_float64: bool = False, lm_slow_share: float = 0.0,
                 background: bool = False, label: str = 'lm',
                 hybrid: HybridModel | None = None, lm_nice: int = NICE
                 ) -> BackPropagation | ReservoirLM | BackgroundLM:
    """Build the trainer called ``name`` (one of :data:`TRAINERS`) for ``model``.

    ``reservoir_size``, ``lm_interval``, ``lm_steps``, ``seed``, ``lm_float64`` and
    ``lm_slow_share`` are :class:`ReservoirLM`'s (the node's parameters of those names);
    BP uses the network's own learning rate and momentum. ``background``: ``lm`` learns in
    a process beside the caller (:class:`BackgroundLM`, ``lm_interval`` then the least
    samples between two updates, ``label`` naming its process, ``hybrid`` the hybrid
    ``model`` is the network of, learnt on its residuals there, ``lm_nice`` the niceness
    the process adds); BP stays per sample.
    """
    if name == 'bp':
        return BackPropagation(model)
    if name == 'lm' and background:
        return BackgroundLM(model, LearnerSettings(
            reservoir_size=reservoir_size, lm_interval=lm_interval, lm_steps=lm_steps,
            seed=seed, lm_float64=lm_float64, lm_slow_share=lm_slow_share, lm_nice=lm_nice,
            label=label), hybrid=hybrid)
    if name == 'lm':
        return ReservoirLM(model, reservoir_size=reservoir_size, lm_interval=lm_interval,
                           lm_steps=lm_steps, seed=seed, lm_float64=lm_float64,
                           lm_slow_share=lm_slow_share)
    raise ValueError(f'unknown trainer {name!r}; choose from {TRAINERS}')


def starts_with_friction_steps(name: str, enabled: bool) -> bool:
    """Whether trainer ``name``'s fresh network starts with friction steps when the option
    (the node's ``lm_friction_steps``) is ``enabled``: ``lm`` only; the paper's ``bp``
    keeps all-random weights."""
    return enabled and name == 'lm'
