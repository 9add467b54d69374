"""Online learning of a hybrid model: the physical model by RLS, a network on its residual.

Each sample is predicted a priori by both parts (the physical model's θ and the network's
weights of the moment); then the physical model takes the sample into recursive least
squares and the network's trainer takes the residual ``y − physical(x)`` of that a-priori
physical prediction. The physical part explains what the URDF's structure can (inertias,
viscous and Coulomb friction, rotor inertia: it converges in seconds); the network learns
what is left (friction shapes, unmodelled effects), starting from zero output so that the
hybrid begins as the physical model.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.dynamics.hybrid_model import HybridModel
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
        The residual network's trainer (``lm``, beside the stream in the identifier).
    """

    name = 'hybrid'

    def __init__(self, model: HybridModel, network_trainer: Trainer) -> None:
        self.model = model
        self.physical = RecursiveLeastSquaresTrainer(model.physical)
        self.network = network_trainer

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the a-priori prediction of ``y`` (n,) from ``x`` (3n,), then learn both
        parts from the sample.

        Raises
        ------
        ValueError
            If the physical step was refused (not finite); nothing was learnt.
        """
        physical = self.physical.learn(x, y)
        return physical + self.network.learn(x, y - physical)
