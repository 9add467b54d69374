"""Online learning of a hybrid model: the physical model by RLS, a network on its residual.

Each sample is predicted a priori by both parts (the physical model's θ and the network's
weights of the moment); then the physical model takes the sample into recursive least
squares and the network learns the residual τ − Y θ. The physical part explains what the
URDF's structure can (inertias, viscous and Coulomb friction, rotor inertia: it converges in
seconds); the network learns what is left (friction shapes, unmodelled effects), starting
from zero output so that the hybrid begins as the physical model.

Which θ the residual is of matters. θ moves most in the first seconds, from the URDF's
inertias and no friction to the stream's fit; a residual taken with the a-priori θ of its
sample stays in the network's reservoir long after θ has moved on, and the network learns
the physical model's early errors as if they were the robot's. With a synchronous ``lm``
trainer (:class:`~scara_ident_ros.identification.trainer.ReservoirLM`) the hybrid
therefore keeps its own reservoir of (x, τ, Y(x)) and gives each Levenberg–Marquardt update
the residuals τ − Y θ of the current θ (a product with the stored regressor rows, no new
dynamics). Another trainer (``bp``, or ``lm`` in a process of its own) takes the a-priori
residual of each sample, unchecked and unbounded.

A network fitted to a small residual overfits easily (offline, ``fit_hybrid`` stops early
for that reason), and extrapolates on states the stream never held. So the synchronous
hybrid keeps :data:`VALIDATION_SHARE` of its samples apart, never learnt by the network,
and checks each update on their residuals (of the current θ): an update that raises the
validation error (per joint, relative to its effort variance, summed) is undone, and a
joint whose residual the network predicts worse than zero gets its output row reset to
zero: the hybrid is then the physical model on that joint until an update earns it back.
The validation samples come from the stream, so after each update the model's correction
is also bounded by the range of the residuals it was fitted to
(:attr:`HybridModel.bounds`): frozen, it cannot extrapolate further than that on motions
the stream never held. What each of these changed, measured: docs/results_arms.md.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.dynamics.hybrid_model import HybridModel
from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.identification.rls_trainer import RecursiveLeastSquaresTrainer
from scara_ident_ros.identification.reservoir_lm import ReservoirLM
from scara_ident_ros.identification.trainer import Trainer
from scara_ident_ros.nn import FeedForwardNet

__all__ = ['HybridTrainer', 'MIN_VALIDATION', 'VALIDATION_SHARE']

#: Share of a synchronous hybrid's samples kept to check its network's updates.
VALIDATION_SHARE = 0.2
#: Validation samples needed before the network's first update.
MIN_VALIDATION = 100


class HybridTrainer:
    """Learn a :class:`HybridModel` online (module docstring).

    Parameters
    ----------
    model : HybridModel
        The model whose two parts are learnt in place.
    network_trainer : Trainer
        The residual network's trainer (``lm``, beside the stream in the identifier). A
        :class:`ReservoirLM` is driven with the residuals of the current θ, every
        ``interval`` of its samples, on a reservoir of the hybrid's of the same capacity
        (its own reservoirs stay empty).
    seed : int
        Seed of that reservoir's draws.
    """

    name = 'hybrid'

    def __init__(self, model: HybridModel, network_trainer: Trainer, *,
                 seed: int = 0) -> None:
        self.model = model
        self.physical = RecursiveLeastSquaresTrainer(model.physical)
        self.network = network_trainer
        self.reservoir: Reservoir | None = None
        if isinstance(network_trainer, ReservoirLM):
            n, p = model.n_outputs, model.physical.n_parameters
            slow = network_trainer.slow
            capacity = network_trainer.reservoir.capacity + (slow.capacity if slow else 0)
            self._shape = (n, p)
            # the targets' columns: τ (n), then the regressor rows Y(x) (n·p)
            self.reservoir = Reservoir(capacity, model.n_inputs, n + n * p, seed=seed)
            self.validation = Reservoir(max(round(capacity * VALIDATION_SHARE), MIN_VALIDATION),
                                        model.n_inputs, n + n * p, seed=seed + 1)
            self._draw = np.random.default_rng(seed + 2)
            self._since = 0
        self.undone = 0  # network updates undone by the validation check

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the a-priori prediction of ``y`` (n,) from ``x`` (3n,), then learn both
        parts from the sample.

        Raises
        ------
        ValueError
            If the physical step was refused (not finite); nothing was learnt.
        """
        if self.reservoir is None:
            physical = self.physical.learn(x, y)
            return physical + self.network.learn(x, y - physical)
        physical, rows = self.physical.learn_rows(x, y)
        predicted = physical + self.model.correction(x)
        kept = np.concatenate([y, rows.reshape(-1)])
        if self._draw.random() < VALIDATION_SHARE:
            self.validation.add(x, kept)
        else:
            self.reservoir.add(x, kept)
        self._since += 1
        if isinstance(self.network, ReservoirLM) and self._since >= self.network.interval:
            self._since = 0
            self.step()
        return predicted

    def step(self) -> bool:
        """One update of the network on the reservoir's residuals of the current θ; return
        whether its weights changed (False without a reservoir of its own)."""
        if (self.reservoir is None or not isinstance(self.network, ReservoirLM)
                or len(self.validation) < MIN_VALIDATION):
            return False
        net = self.model.network
        x_val, r_val = self.validation.X, self._residual(self.validation)
        scale = np.maximum(self.validation.Y[:, :self._shape[0]].var(axis=0), 1e-300)
        before = net.get_params()
        error = _errors(self.model, x_val, r_val) / scale
        residual = self._residual(self.reservoir)
        self.model.bounds = (residual.min(axis=0), residual.max(axis=0))
        changed = self.network.step_on(self.reservoir.X.copy(), residual)
        if not changed:
            return False
        after = _errors(self.model, x_val, r_val) / scale
        if after.sum() > error.sum():
            net.set_params(before)
            self.undone += 1
            return False
        worse = after > np.mean(r_val ** 2, axis=0) / scale  # than predicting no residual
        if np.any(worse):
            _zero_outputs(net, worse)
        return True

    def _residual(self, store: Reservoir) -> NDArray[np.float64]:
        """τ − Y(x) θ of the stored samples, θ the physical model's now: (m, n)."""
        n, p = self._shape
        stored = store.Y
        return stored[:, :n] - stored[:, n:].reshape(-1, n, p) @ self.model.physical.theta


def _errors(model: HybridModel, X: NDArray[np.float64],
            residual: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mean squared error per joint of the (bounded) correction's ``residual`` (n,)."""
    return np.asarray(np.mean((model.correction(X) - residual) ** 2, axis=0))


def _zero_outputs(net: FeedForwardNet, joints: NDArray[np.bool_]) -> None:
    """Make ``net`` predict 0 for ``joints`` (n,) (their output rows as ``start_at_zero``)."""
    theta = net.get_params()
    _, output = net.unpack(theta)
    output[joints, :-1] = 0.0
    output[joints, -1] = net.y_scaling.transform(np.zeros(net.n_outputs))[joints]
    net.set_params(theta)
