"""Offline training of a `FeedForwardNet` on a batch: the entry point over the algorithms.

`fit` runs one algorithm on given data; `train_offline` is the project's default offline
training over it (what ``scara-ident train`` and ``FeedForwardNet.fit`` do): validation
blocks held out of the samples, at most `SAMPLES` training samples, Levenberg–Marquardt
early-stopped on the validation blocks. Its defaults were chosen with
benchmarks/bench_train_defaults.py (docs/results.md).
"""
from __future__ import annotations

import operator
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from scara_ident_ros.nn.batch import mse_scaled
from scara_ident_ros.nn.gradient_descent import GradientDescent
from scara_ident_ros.nn.levenberg_marquardt import LevenbergMarquardt
from scara_ident_ros.nn.scaling import MinMaxScaling
from scara_ident_ros.nn.training import Callback, FitHistory, run_training
from scara_ident_ros.nn.validation_blocks import VALIDATION_FRACTION, row_split

if TYPE_CHECKING:
    from scara_ident_ros.nn.network import FeedForwardNet

__all__ = ['ALGORITHMS', 'ITERATIONS', 'MAX_FAIL', 'MIN_ITERATIONS', 'SAMPLES', 'fit',
           'train_offline']

#: Offline training algorithms accepted by `fit`.
ALGORITHMS = ('lm', 'gd')
#: Defaults of `train_offline` (and so of ``scara-ident train``).
ITERATIONS = 500           # Levenberg–Marquardt iterations at most
SAMPLES = 8000             # training samples drawn from the training blocks
MAX_FAIL = 50              # validation failures in a row that stop training
MIN_ITERATIONS = 50        # iterations before validation failures count


def fit(net: FeedForwardNet, X: npt.ArrayLike, Y: npt.ArrayLike, *, algorithm: str = 'lm',
        iterations: int = 315, goal: float = 0.0,
        validation: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
        max_fail: int = 6, min_iterations: int = 0,
        callback: Callback | None = None, weight_decay: float = 0.0) -> FitHistory:
    """Train ``net`` offline on a batch of samples, in place.

    If the scaling was never set, it is first fitted to the minima and maxima of X and Y
    (later calls keep it). Training minimises the mean squared error of the scaled
    outputs (`FitHistory` explains the figures it records).

    Parameters
    ----------
    net : FeedForwardNet
    X : array_like of shape (n_samples, n_inputs)
        Physical inputs.
    Y : array_like of shape (n_samples, n_outputs)
        Physical targets.
    algorithm : {'lm', 'gd'}, default 'lm'
        Levenberg–Marquardt (like MATLAB's trainlm: mu from 1e-3, ×10 on failure, ÷10
        on success, stop above 1e10), or batch gradient descent with momentum (the
        paper's BP; uses the network's `learning_rate` and `momentum` on the mean over
        samples of ½·Σ_j e_j²).
    iterations : int, default 315
        Iteration limit (the paper's Table 2 trains 315).
    goal : float, default 0.0
        Stop when the training MSE of the scaled outputs is <= goal.
    validation : (X_val, Y_val), optional
        Physical validation data: stop after ``max_fail`` iterations in a row without a
        new best validation MSE, counted after the first ``min_iterations``, and end
        with the best-validation weights.
    max_fail : int, default 6
        See ``validation`` (MATLAB's default).
    min_iterations : int, default 0
        Iterations whose validation failures do not count (see ``validation``).
    callback : callable, optional
        ``callback(history)`` after each iteration; returning True stops training.
    weight_decay : float, default 0.0
        λ ≥ 0: Levenberg–Marquardt minimises Σ e² + λ‖θ‖² over the scaled errors e of all
        samples and outputs and every weight θ (`LevenbergMarquardt`); 0: no penalty.
        Only with ``algorithm='lm'``.

    Returns
    -------
    FitHistory
        Also resets the momentum of `FeedForwardNet.partial_fit`.
    """
    if algorithm not in ALGORITHMS:
        raise ValueError(f'algorithm {algorithm!r} is not one of {ALGORITHMS}')
    x = net.check_inputs(np.asarray(X, dtype=np.float64), 'X')
    y = net.check_outputs(np.asarray(Y, dtype=np.float64), x.shape[0])
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError('X and Y must be finite')
    iterations = operator.index(iterations)
    max_fail = operator.index(max_fail)
    min_iterations = operator.index(min_iterations)
    if iterations < 0 or max_fail < 1 or min_iterations < 0:
        raise ValueError('need iterations >= 0, max_fail >= 1 and min_iterations >= 0')
    if weight_decay and algorithm != 'lm':
        raise ValueError(f'weight_decay needs algorithm \'lm\', got {algorithm!r}')
    if not net.scaling_set:
        xsc, ysc = MinMaxScaling.from_data(x), MinMaxScaling.from_data(y)
        net.set_scaling(xsc.lo, xsc.hi, ysc.lo, ysc.hi)
    xs, ys = net.x_scaling.transform(x), net.y_scaling.transform(y)
    validation_mse = None
    if validation is not None:
        xv = net.check_inputs(np.asarray(validation[0], dtype=np.float64), 'X_val')
        yv = net.check_outputs(np.asarray(validation[1], dtype=np.float64), xv.shape[0])
        validation_mse = partial(mse_scaled, net, net.x_scaling.transform(xv),
                                 net.y_scaling.transform(yv))
    step = (LevenbergMarquardt(net, xs, ys, weight_decay=weight_decay) if algorithm == 'lm'
            else GradientDescent(net, xs, ys))
    history = run_training(net, algorithm, step, iterations=iterations, goal=float(goal),
                           validation_mse=validation_mse, max_fail=max_fail,
                           min_iterations=min_iterations, callback=callback)
    net.reset_momentum()
    return history


def train_offline(net: FeedForwardNet, X: npt.ArrayLike, Y: npt.ArrayLike, *,
                  validation: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
                  validation_fraction: float = VALIDATION_FRACTION, samples: int = SAMPLES,
                  seed: int = 0, algorithm: str = 'lm', iterations: int = ITERATIONS,
                  goal: float = 0.0, max_fail: int = MAX_FAIL,
                  min_iterations: int = MIN_ITERATIONS,
                  callback: Callback | None = None, weight_decay: float = 0.0) -> FitHistory:
    """The project's default offline training of ``net`` (module docstring), in place.

    Parameters
    ----------
    net : FeedForwardNet
    X : array_like of shape (n_samples, n_inputs)
        Physical inputs, rows in time order.
    Y : array_like of shape (n_samples, n_outputs)
        Physical targets.
    validation : (X_val, Y_val), optional
        Validation samples; if None, blocks of consecutive rows of X, Y (a
        ``validation_fraction`` of them, spread over the rows:
        `validation_blocks.row_split`) validate and the others train.
    validation_fraction : float, default 0.2
        See ``validation``; 0: no validation, no early stop.
    samples : int, default 8000
        Train on at most this many training samples drawn at random (0: all).
    seed : int, default 0
        Seed of the validation blocks and of the draw.
    algorithm, iterations, goal, max_fail, min_iterations, callback, weight_decay
        As `fit`.

    Returns
    -------
    FitHistory
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    samples = operator.index(samples)
    if samples < 0:
        raise ValueError(f'samples must not be negative, got {samples}')
    if validation is None and x.ndim == 2 and x.shape[0] == y.shape[0]:
        train, held = row_split(x.shape[0], validation_fraction, seed=seed)
        if held.shape[0]:
            validation = (x[held], y[held])
            x, y = x[train], y[train]
    if samples and samples < x.shape[0]:
        rows = np.sort(np.random.default_rng(seed).choice(x.shape[0], samples, replace=False))
        x, y = x[rows], y[rows]
    return fit(net, x, y, algorithm=algorithm, iterations=iterations, goal=goal,
               validation=validation, max_fail=max_fail, min_iterations=min_iterations,
               callback=callback, weight_decay=weight_decay)
