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
dynamics). With ``lm`` in a learner process (the identifier's default, ``lm_background``),
the same happens there: the message path sends (x, τ) and the latest θ, the learner keeps
the reservoir and computes Y(x) for the samples it keeps (one shared definition:
:class:`~scara_ident_ros.identification.residual_learner.ResidualLearner`). ``bp`` takes
the a-priori residual of each sample, unchecked and unbounded.

A network fitted to a small residual overfits easily (offline, ``fit_hybrid`` stops early
for that reason), and extrapolates on states the stream never held. So an ``lm`` hybrid
keeps a share of its samples apart
(:data:`~scara_ident_ros.identification.residual_learner.VALIDATION_SHARE`), never learnt by
the network, and checks each update on their residuals (of the current θ): an update that
raises the validation error (per joint, relative to its effort variance, summed) is undone,
and a joint whose residual the network predicts worse than zero is gated off
(:attr:`HybridModel.gate`): the hybrid is then the physical model on that joint until an
update earns it back. The
validation samples come from the stream, so after each update the model's correction is also
bounded by the range of the residuals it was fitted to (:attr:`HybridModel.bounds`): frozen,
it cannot extrapolate further than that on motions the stream never held. What each of these
changed, measured: docs/results.md (other arms).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.learners.hybrid_model import HybridModel
from scara_ident_ros.identification.background_lm import BackgroundLM
from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.identification.reservoir_lm import ReservoirLM
from scara_ident_ros.identification.residual_learner import ResidualLearner
from scara_ident_ros.identification.rls_trainer import RecursiveLeastSquaresTrainer
from scara_ident_ros.identification.trainer import Trainer

__all__ = ['HybridTrainer']


class HybridTrainer:
    """Learn a :class:`HybridModel` online (module docstring).

    Parameters
    ----------
    model : HybridModel
        The model whose two parts are learnt in place.
    network_trainer : Trainer
        The residual network's trainer. A :class:`ReservoirLM` is driven through a
        :class:`ResidualLearner` with the residuals of the current θ, every ``interval`` of
        its samples (its own reservoirs stay empty). A :class:`BackgroundLM` made for this
        model (its ``hybrid``) runs the same :class:`ResidualLearner` in its learner
        process: the message path hands it (x, τ) and θ, nothing more.
    seed : int
        Seed of the reservoirs' draws (synchronous; a background learner has its own).
    """

    name = 'hybrid'

    def __init__(self, model: HybridModel, network_trainer: Trainer, *,
                 seed: int = 0) -> None:
        self.model = model
        self.physical = RecursiveLeastSquaresTrainer(model.physical)
        self.network = network_trainer
        self.residual: ResidualLearner | None = None
        self._background = (isinstance(network_trainer, BackgroundLM)
                            and network_trainer.hybrid is model)
        if isinstance(network_trainer, ReservoirLM):
            self.residual = ResidualLearner(model, network_trainer, seed=seed)
            self._lm = network_trainer
            self._since = 0

    @property
    def undone(self) -> int:
        """Network updates undone by the validation check."""
        if self.residual is not None:
            return self.residual.undone
        return self.network.undone if isinstance(self.network, BackgroundLM) else 0

    @property
    def validation(self) -> Reservoir:
        """The synchronous network's validation samples.

        Raises
        ------
        AttributeError
            Without a synchronous ``lm`` network.
        """
        if self.residual is None:
            raise AttributeError('only a synchronous lm network has validation samples here')
        return self.residual.validation

    @property
    def reservoir(self) -> Reservoir | None:
        """The synchronous network's samples (None without a synchronous ``lm`` network)."""
        return None if self.residual is None else self.residual.reservoir

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the a-priori prediction of ``y`` (n,) from ``x`` (3n,), then learn both
        parts from the sample.

        Raises
        ------
        ValueError
            If the physical step was refused (not finite); nothing was learnt.
        """
        if self._background:
            physical = self.physical.learn(x, y)
            predicted = physical + self.model.correction(x)
            assert isinstance(self.network, BackgroundLM)
            self.network.add(x, y)
            return predicted
        if self.residual is None:
            physical = self.physical.learn(x, y)
            return physical + self.network.learn(x, y - physical)
        physical, rows = self.physical.learn_rows(x, y)
        predicted = physical + self.model.correction(x)
        self.residual.add(x, y, rows)
        self._since += 1
        if self._since >= self._lm.lm_interval:
            self._since = 0
            self.step()
        return predicted

    def step(self) -> bool:
        """One update of the network on the reservoir's residuals of the current θ; return
        whether its weights changed (False without a synchronous ``lm`` network)."""
        if self.residual is None:
            return False
        return self.residual.step(
            self.residual.snapshot(self.model.physical.theta, copy=False))
