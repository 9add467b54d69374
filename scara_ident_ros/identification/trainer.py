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

``'lm'`` (:class:`ReservoirLM`, the default)
    Every sample goes into a :class:`Reservoir`, a uniform random sample of the whole stream
    so far (``capacity`` samples); every ``interval`` samples the network takes ``steps``
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
    (benchmarks/bench_lm_variants.py): ``float64`` assembles JᵀJ in float64, and
    ``slow_share`` keeps that share of the reservoir for samples where some joint moves
    slower than 1 % of its velocity input's half-range (:data:`SLOW_FRACTION`): the samples
    around q' = 0, where the Coulomb step is, a small share of a stream.

Both give the a-priori prediction of each sample, made before the sample is learnt.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.scaling import MinMaxScaling
from scara_ident_ros.nn.levenberg_marquardt import LevenbergMarquardt
from scara_ident_ros.nn.training import StopTraining

if TYPE_CHECKING:  # background_lm's learner process imports this module
    from scara_ident_ros.identification.background_lm import BackgroundLM

__all__ = ['Trainer', 'BackPropagation', 'ReservoirLM', 'TRAINERS', 'make_trainer',
           'starts_with_friction_steps']

#: Names of the online trainers; ``'lm'`` is the default.
TRAINERS = ('lm', 'bp')

LM_MU = 1e-3  # initial (and restart) damping of the reservoir LM
#: A sample is slow (``ReservoirLM``'s ``slow_share``) when some joint's |q'| is below this
#: fraction of the half-range of the network's velocity input (of v_max with limit scaling).
SLOW_FRACTION = 0.01
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
        """Efforts (n,) of one input (3n,) (see ``EffortModel``)."""
        ...

    def partial_fit(self, X: NDArray[np.float64],
                    Y: NDArray[np.float64]) -> NDArray[np.float64]:
        """One step per row; the a-priori errors (see ``EffortModel``)."""
        ...

    @property
    def y_scaling(self) -> MinMaxScaling:
        """The outputs' scaling (errors are compared in scaled units)."""
        ...

    def get_params(self) -> NDArray[np.float64]:
        """A copy of the weights, shape (n_params,)."""
        ...

    def set_params(self, theta: NDArray[np.float64]) -> None:
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
    model : SteppedModel or EffortModel
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
        before = model.get_params()
        prior = model.partial_fit(x[np.newaxis], y[np.newaxis])[0]
        gain = model.y_scaling.gain
        post = (y - model.predict(x)) * gain
        prior_scaled = prior * gain
        prior_sq = float(prior_scaled @ prior_scaled)
        self._typical += TYPICAL_WEIGHT * (prior_sq - self._typical)
        limit = GROWTH * max(prior_sq, self._typical) + GUARD_FLOOR * y.shape[0]
        if not float(post @ post) <= limit:
            model.set_params(before)
            model.reset_momentum()
            model.learning_rate = model.learning_rate / 2.0
            self.undone += 1
            raise ValueError('the step overshot: the error on its own sample grew from '
                             f'{prior_sq:.3g} to '
                             f'{float(post @ post):.3g} (scaled); undone, learning rate '
                             f'now {model.learning_rate:.3g}')
        return y - prior


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
    float64 : bool
        Assemble JᵀJ in float64 (more CPU) instead of float32.
    slow_share : float
        Share of ``capacity`` in [0, 0.5] kept for slow samples (some joint below
        :data:`SLOW_FRACTION` of its velocity input's half-range), in a reservoir of their
        own; 0: one uniform reservoir. The inputs are (q, q', q'') of n joints each.
    """

    name = 'lm'

    def __init__(self, model: FeedForwardNet, *, capacity: int = 4000, interval: int = 200,
                 steps: int = 2, seed: int = 0, float64: bool = False,
                 slow_share: float = 0.0) -> None:
        if interval < 1 or steps < 1:
            raise ValueError(f'need interval >= 1 and steps >= 1, got {interval}, {steps}')
        if not 0.0 <= slow_share <= 0.5:
            raise ValueError(f'slow_share must be in [0, 0.5], got {slow_share}')
        self.model = model
        self.interval = int(interval)
        self.steps_per_update = int(steps)
        self.float64 = bool(float64)
        n_slow = round(capacity * slow_share)
        self.reservoir = Reservoir(capacity - n_slow, model.n_inputs, model.n_outputs,
                                   seed=seed)
        self.slow: Reservoir | None = None
        if n_slow:
            self.slow = Reservoir(n_slow, model.n_inputs, model.n_outputs, seed=seed + 1)
            n = model.n_inputs // 3
            self._velocities = slice(n, 2 * n)
            scaling = model.x_scaling
            half = (scaling.hi[self._velocities] - scaling.lo[self._velocities]) / 2.0
            self._slow_below = SLOW_FRACTION * np.abs(half)  # (n,) physical speeds
        self.steps = 0  # LM steps taken
        self._since = 0  # samples since the last step
        self._lm: LevenbergMarquardt | None = None

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Predict, keep the sample in the reservoir, and step every ``interval`` samples."""
        predicted = self.model.predict(x)
        self.add(x, y)
        self._since += 1
        if self._since >= self.interval:
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
        """Take ``steps`` LM steps on the reservoir now; return whether the weights changed."""
        return self.step_on(*self.samples())

    def step_on(self, X: NDArray[np.float64], Y: NDArray[np.float64]) -> bool:
        """Take ``steps`` LM steps on the samples X (m, 3n), Y (m, n) (physical units, e.g.
        a copy of :meth:`samples`); return whether the weights changed."""
        if len(X) < 2:
            return False
        model = self.model
        xs = model.x_scaling.transform(X)
        ys = model.y_scaling.transform(Y)
        if self._lm is None:
            self._lm = LevenbergMarquardt(model, xs, ys, mu=LM_MU, single=not self.float64)
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
                 interval: int = 200, steps: int = 2, seed: int = 0, float64: bool = False,
                 slow_share: float = 0.0, background: bool = False, label: str = 'lm'
                 ) -> BackPropagation | ReservoirLM | BackgroundLM:
    """Build the trainer called ``name`` (one of :data:`TRAINERS`) for ``model``.

    ``capacity``, ``interval``, ``steps``, ``seed``, ``float64`` and ``slow_share`` are
    :class:`ReservoirLM`'s; BP uses the network's own learning rate and momentum.
    ``background``: ``lm`` learns in a process beside the caller (:class:`BackgroundLM`,
    ``interval`` then the least samples between two updates, ``label`` naming its process);
    BP stays per sample.
    """
    if name == 'bp':
        return BackPropagation(model)
    if name == 'lm' and background:
        from scara_ident_ros.identification.background_lm import BackgroundLM, LearnerSettings
        return BackgroundLM(model, LearnerSettings(
            capacity=capacity, interval=interval, steps=steps, seed=seed, float64=float64,
            slow_share=slow_share, label=label))
    if name == 'lm':
        return ReservoirLM(model, capacity=capacity, interval=interval, steps=steps,
                           seed=seed, float64=float64, slow_share=slow_share)
    raise ValueError(f'unknown trainer {name!r}; choose from {TRAINERS}')


def starts_with_friction_steps(name: str, enabled: bool) -> bool:
    """Whether trainer ``name``'s fresh network starts with friction steps when the option
    (the node's ``lm_friction_steps``) is ``enabled``: ``lm`` only; the paper's ``bp``
    keeps all-random weights."""
    return enabled and name == 'lm'
