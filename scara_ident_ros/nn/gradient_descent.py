"""Batch gradient descent with momentum: the paper's (offline) back-propagation.

Each iteration uses the gradient of L = mean over samples of ½·Σ_j e_j² (scaled errors)::

    v ← momentum·v − learning_rate·∇L(θ);   θ ← θ + v

with the network's `learning_rate` and `momentum`.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from scara_ident_ros.nn.batch import loss_gradient
from scara_ident_ros.nn.training import STOP_DIVERGED, FitHistory, StopTraining

if TYPE_CHECKING:
    from scara_ident_ros.nn.network import FeedForwardNet

__all__ = ['GradientDescent']

FloatArray = npt.NDArray[np.float64]


class GradientDescent:
    """A `training.TrainingStep` (and its ``net, xs, ys``) doing batch gradient descent
    with momentum."""

    def __init__(self, net: FeedForwardNet, xs: FloatArray, ys: FloatArray) -> None:
        self._net, self._xs, self._ys = net, xs, ys
        self._velocity = np.zeros(net.n_params)
        self._previous = np.empty(net.n_params)
        self._gradient = np.zeros(net.n_params)
        self._size = ys.size

    def start(self, history: FitHistory) -> float:
        """Return the training MSE at the current weights (and keep their gradient)."""
        sse, self._gradient = loss_gradient(self._net, self._xs, self._ys)
        return sse / self._size

    def step(self) -> float:
        """Make one step; return the training MSE after it.

        Raises
        ------
        StopTraining
            'diverged' if the error became infinite or NaN; the weights are then restored.
        """
        net = self._net
        theta = net.theta
        self._velocity *= net.momentum
        self._velocity -= net.learning_rate * self._gradient
        np.copyto(self._previous, theta)
        theta += self._velocity
        sse, self._gradient = loss_gradient(net, self._xs, self._ys)
        if not math.isfinite(sse):
            np.copyto(theta, self._previous)
            raise StopTraining(STOP_DIVERGED)
        return sse / self._size
