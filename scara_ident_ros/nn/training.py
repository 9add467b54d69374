"""The frame shared by offline training algorithms: stop rules, validation, history.

An algorithm supplies a `TrainingStep`; `run_training` iterates it, records a `FitHistory`,
and stops at the error goal, the iteration limit, when the validation error has failed to
improve ``max_fail`` times in a row, when the algorithm cannot go on, or when the callback
asks to. Validation failures count only after the first ``min_iterations`` iterations (0:
from the first, as MATLAB's ``train``): Levenberg–Marquardt's first steps, while its damping
is still adapting, often raise the validation error before they lower it. When validation
data are given, the network ends with the weights of the best validation error seen,
whatever the reason for stopping (as MATLAB's ``train`` does), a best seen during the first
``min_iterations`` included.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

import numpy as np
import numpy.typing as npt

__all__ = [
    'STOP_CALLBACK',
    'STOP_DIVERGED',
    'STOP_GOAL',
    'STOP_ITERATIONS',
    'STOP_MU_MAX',
    'STOP_VALIDATION',
    'Callback',
    'FitHistory',
    'StopTraining',
    'TrainingStep',
    'Weights',
    'run_training',
]

FloatArray = npt.NDArray[np.float64]

STOP_GOAL = 'goal'  #: the training MSE reached the goal
STOP_ITERATIONS = 'iterations'  #: the iteration limit was reached
#: the validation MSE failed to improve max_fail times in a row (after min_iterations)
STOP_VALIDATION = 'validation'
STOP_MU_MAX = 'mu_max'  #: Levenberg–Marquardt's damping exceeded its maximum
STOP_DIVERGED = 'diverged'  #: a step made the error infinite or NaN (weights kept from before)
STOP_CALLBACK = 'callback'  #: the callback returned True


class StopTraining(Exception):
    """Raised by a `TrainingStep` that cannot go on; ``reason`` is one of the STOP_ names."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass
class FitHistory:
    """What an offline training run did.

    All errors are mean squared errors of the *scaled* outputs (each output mapped to
    [-1, 1] by the network's output scaling), averaged over samples and outputs: the
    quantity compared with ``goal``. Multiply by (range/2)² of an output for physical units.

    Attributes
    ----------
    algorithm : str
        ``'lm'`` or ``'gd'``.
    mse : list of float, length iterations + 1
        Training MSE before training (index 0) and after each iteration.
    val_mse : list of float or None
        Validation MSE at the same points, or None without validation data.
    time : list of float, length iterations
        Wall time of each iteration in seconds (the callback excluded).
    mu : list of float
        Levenberg–Marquardt damping of each accepted step; empty for ``'gd'``.
    stop_reason : str
        One of 'goal', 'iterations', 'validation', 'mu_max', 'diverged', 'callback'.
    iterations : int
        Iterations done.
    best_iteration : int
        The iteration whose weights the network holds at the end (the last one without
        validation data; the one of the lowest validation MSE with them).
    """

    algorithm: str
    mse: list[float] = field(default_factory=list)
    val_mse: list[float] | None = None
    time: list[float] = field(default_factory=list)
    mu: list[float] = field(default_factory=list)
    stop_reason: str = ''
    iterations: int = 0
    best_iteration: int = 0

    @property
    def final_mse(self) -> float:
        """Training MSE of the weights the network holds at the end."""
        return self.mse[self.best_iteration]


class Weights(Protocol):
    """What `run_training` reads of a network: its packed weights, to keep the best."""

    def get_theta(self) -> FloatArray:
        """Return a copy of the packed weights."""

    def set_theta(self, theta: npt.ArrayLike) -> None:
        """Copy packed weights into the network."""


class TrainingStep(Protocol):
    """One offline training algorithm, bound to a network and its scaled data.

    The algorithms (`GradientDescent`, `LevenbergMarquardt`) are built as
    ``Algorithm(net, xs, ys, **options)``: the `FeedForwardNet` they train in place, the
    scaled inputs xs (n_samples, n_inputs) and the scaled targets ys (n_samples, n_outputs).
    """

    def start(self, history: FitHistory) -> float:
        """Prepare (keeping ``history`` to record into); return the current training MSE."""

    def step(self) -> float:
        """Change the network's weights by one iteration; return the new training MSE.

        Raises `StopTraining` when no step can be made.
        """


#: ``callback(history)`` after each iteration; a true result stops training.
Callback = Callable[[FitHistory], 'bool | None']


def run_training(net: Weights, algorithm: str, step: TrainingStep, *,
                 iterations: int, goal: float, validation_mse: Callable[[], float] | None,
                 max_fail: int, callback: Callback | None,
                 min_iterations: int = 0) -> FitHistory:
    """Iterate ``step`` under the stop rules of the module docstring.

    Parameters
    ----------
    net : Weights
        The network ``step`` trains; its best weights are kept and restored.
    algorithm : str
        Name recorded in the history.
    step : TrainingStep
        The algorithm.
    iterations : int
        Iteration limit (>= 0).
    goal : float
        Stop as soon as the training MSE is <= goal.
    validation_mse : callable or None
        The network's validation MSE at its current weights, in scaled units.
    max_fail : int
        Consecutive validation failures that stop training.
    callback : callable or None
        Called with the history after each iteration; returning True stops training.
    min_iterations : int
        Iterations whose validation failures do not count (>= 0): the earliest validation
        stop is after iteration ``min_iterations + max_fail``.

    Returns
    -------
    FitHistory
    """
    history = FitHistory(algorithm=algorithm)
    history.mse.append(step.start(history))
    best_params: FloatArray | None = None
    best_val = math.inf
    fails = 0
    if validation_mse is not None:
        history.val_mse = [validation_mse()]
        best_val = history.val_mse[0]
        best_params = net.get_theta()
    reason = STOP_GOAL if history.mse[0] <= goal else ''
    while not reason:
        if history.iterations >= iterations:
            reason = STOP_ITERATIONS
            break
        start = time.perf_counter()
        try:
            mse = step.step()
        except StopTraining as stop:
            reason = stop.reason
            break
        history.iterations += 1
        history.mse.append(mse)
        if validation_mse is not None and history.val_mse is not None:
            val = validation_mse()
            history.val_mse.append(val)
            if val < best_val:
                best_val, fails = val, 0
                best_params = net.get_theta()
                history.best_iteration = history.iterations
            elif history.iterations > min_iterations:
                fails += 1
        else:
            history.best_iteration = history.iterations
        history.time.append(time.perf_counter() - start)
        if mse <= goal:
            reason = STOP_GOAL
        elif validation_mse is not None and fails >= max_fail:
            reason = STOP_VALIDATION
        elif callback is not None and callback(history):
            reason = STOP_CALLBACK
    history.stop_reason = reason
    if best_params is not None:
        net.set_theta(best_params)
    return history
