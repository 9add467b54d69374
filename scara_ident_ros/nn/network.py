"""The feed-forward network of the paper: one hidden layer, linear outputs, built-in scaling.

For the SCARA robot it is 12-40-4: inputs q, q', q'' of the 4 joints, outputs the 4 joint
efforts; a robot with n joints gives 3n-H-n. In scaled units (each input and output mapped
to [-1, 1] from its range, like MATLAB's ``mapminmax``) the network computes::

    z = (x·V + c − b) / a                                   (n_hidden,)  eq. 2
    h = k·f(z)          f = sigmoid, SLOG or MSLOG           (n_hidden,)
    y = W·h + d                                              (n_outputs,)

with trainable V (n_inputs, n_hidden), c (n_hidden), W (n_outputs, n_hidden), d (n_outputs)
and fixed constants k, a, b (`activations.DEFAULT_CONSTANTS`). All weights live in one packed
vector ``θ = [Vt.ravel(), Wt.ravel()]`` with Vt = [V; c] of shape (n_inputs + 1, n_hidden) and
Wt = [W, d] of shape (n_outputs, n_hidden + 1); `FeedForwardNet.unpack` returns views.

Public methods take and return physical units; training minimises errors of scaled outputs.
"""
from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Sequence
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np
import numpy.typing as npt

from scara_ident_ros.nn.activations import (ACTIVATIONS, DEFAULT_CONSTANTS,
                                            ActivationConstants, hidden_layer, tanh_form)
from scara_ident_ros.nn.model_file import read_model, write_model
from scara_ident_ros.nn.scaling import MinMaxScaling
from scara_ident_ros.nn.training import Callback, FitHistory, run_training

__all__ = ['ALGORITHMS', 'FeedForwardNet', 'Layers']

FloatArray = npt.NDArray[np.float64]

#: Offline training algorithms accepted by `FeedForwardNet.fit`.
ALGORITHMS = ('lm', 'gd')

_DEFAULT_CHUNK = 1024  # samples per block in batched computations (bounds memory)


class Layers(NamedTuple):
    """Batched forward pass in scaled units, for n samples (`FeedForwardNet.forward_scaled`)."""

    h: FloatArray  # (n, n_hidden) hidden outputs
    g: FloatArray | None  # (n, n_hidden) dh/d(x·v + c) = k·f'(z)/a, if asked for
    y: FloatArray  # (n, n_outputs) scaled outputs


class FeedForwardNet:
    """A n_inputs-n_hidden-n_outputs network with a sigmoid, SLOG or MSLOG hidden layer.

    Parameters
    ----------
    n_inputs, n_hidden, n_outputs : int
        Layer sizes (12, 40, 4 for the paper's SCARA).
    activation : {'mslog', 'slog', 'sigmoid'}, default 'mslog'
        Hidden activation: FFMW, FFW or FFS of the paper.
    seed : int, default 0
        Seed of the weight initialisation; equal seeds give equal networks.
    k, a, b : float, optional
        Constants of h = k·f((x·v + c − b)/a); default per activation (MSLOG: 2.5, 5, 5;
        others 1, 1, 0). ``a`` must be non-zero.
    weight_scale : float, default 2.0
        Initial spread of the hidden units' net input z: each unit starts as
        z = u·x + β with u uniform in ±weight_scale/√n_inputs per input and β uniform in
        ±weight_scale, independently of a and b; output weights start uniform in
        ±1/√n_hidden, output biases at 0.
    learning_rate : float, default 0.05
        Step size of `partial_fit` and of ``fit(algorithm='gd')``.
    momentum : float, default 0.9
        Momentum of the same; 0 gives plain gradient descent.

    Notes
    -----
    Before `set_scaling` or `fit`, inputs and outputs are taken as already scaled
    (identity scaling), `predict` works, and `partial_fit` refuses to learn.

    Not thread-safe: single-sample `predict` and `partial_fit` share preallocated buffers.
    Call one network from one thread at a time (a ROS callback group that is mutually
    exclusive does that).
    """

    def __init__(self, n_inputs: int, n_hidden: int, n_outputs: int,
                 activation: str = 'mslog', *, seed: int = 0, k: float | None = None,
                 a: float | None = None, b: float | None = None, weight_scale: float = 2.0,
                 learning_rate: float = 0.05, momentum: float = 0.9) -> None:
        sizes = []
        for name, value in (('n_inputs', n_inputs), ('n_hidden', n_hidden),
                            ('n_outputs', n_outputs)):
            try:
                size = operator.index(value)
            except TypeError:
                raise TypeError(f'{name} must be an integer, got {value!r}') from None
            if size < 1:
                raise ValueError(f'{name} must be at least 1, got {size}')
            sizes.append(size)
        self._n_in, self._n_hid, self._n_out = sizes
        if activation not in ACTIVATIONS:
            raise ValueError(f'activation {activation!r} is not one of {sorted(ACTIVATIONS)}')
        self._activation = activation
        default = DEFAULT_CONSTANTS[activation]
        constants = ActivationConstants(
            float(default.k if k is None else k), float(default.a if a is None else a),
            float(default.b if b is None else b))
        if not all(math.isfinite(c) for c in constants) or constants.a == 0.0:
            raise ValueError(f'k, a, b must be finite and a non-zero, got {constants}')
        self._constants = constants
        if not (math.isfinite(weight_scale) and weight_scale > 0.0):
            raise ValueError(f'weight_scale must be positive, got {weight_scale}')
        self._weight_scale = float(weight_scale)
        self._seed = operator.index(seed)
        self._learning_rate = _check_rate('learning_rate', learning_rate)
        self._momentum = _check_momentum(momentum)
        #: Free-form arrays saved with the network, e.g. ``{'joint_names': np.array([...])}``.
        self.metadata: dict[str, np.ndarray] = {}

        self._form = tanh_form(activation, constants)

        n_in, n_hid, n_out = sizes
        self._n_hidden_params = (n_in + 1) * n_hid
        self._theta = np.zeros(self.n_params)
        self._velocity = np.zeros(self.n_params)  # momentum of partial_fit
        self._grad = np.zeros(self.n_params)  # partial_fit's step, packed like θ
        self._Vt, self._Wt = self.unpack(self._theta)
        self._initialise_weights()

        self._x_scaling = MinMaxScaling.identity(n_in)
        self._y_scaling = MinMaxScaling.identity(n_out)
        self._scaling_set = False
        # Scaling constants of the hot path, updated in place by set_scaling.
        self._x_gain_t = np.empty(n_in)
        self._x_offset_t = np.empty(n_in)
        self._y_gain = np.empty(n_out)
        self._y_offset = np.empty(n_out)
        self._y_inv_gain = np.empty(n_out)
        self._load_scaling_constants()
        self._step: Callable[[FloatArray, FloatArray], FloatArray] = self._step_unscaled
        self._predict_one, self._online_step = self._build_single_sample_path()

    # ----------------------------------------------------------------------------- properties
    @property
    def n_inputs(self) -> int:
        """Number of inputs."""
        return self._n_in

    @property
    def n_hidden(self) -> int:
        """Number of hidden units."""
        return self._n_hid

    @property
    def n_outputs(self) -> int:
        """Number of outputs."""
        return self._n_out

    @property
    def n_params(self) -> int:
        """Number of weights and biases: (n_inputs + 1)·n_hidden + (n_hidden + 1)·n_outputs."""
        return (self._n_in + 1) * self._n_hid + (self._n_hid + 1) * self._n_out

    @property
    def activation(self) -> str:
        """Name of the hidden activation."""
        return self._activation

    @property
    def constants(self) -> ActivationConstants:
        """The activation constants (k, a, b)."""
        return self._constants

    @property
    def seed(self) -> int:
        """Seed the weights were initialised from."""
        return self._seed

    @property
    def weight_scale(self) -> float:
        """Spread of the initial net inputs (see the class docstring)."""
        return self._weight_scale

    @property
    def learning_rate(self) -> float:
        """Step size of `partial_fit` and of batch gradient descent."""
        return self._learning_rate

    @learning_rate.setter
    def learning_rate(self, value: float) -> None:
        self._learning_rate = _check_rate('learning_rate', value)
        self._predict_one, self._online_step = self._build_single_sample_path()
        if self._scaling_set:
            self._step = self._online_step

    @property
    def momentum(self) -> float:
        """Momentum of `partial_fit` and of batch gradient descent, in [0, 1)."""
        return self._momentum

    @momentum.setter
    def momentum(self, value: float) -> None:
        self._momentum = _check_momentum(value)
        self._predict_one, self._online_step = self._build_single_sample_path()
        if self._scaling_set:
            self._step = self._online_step

    @property
    def x_scaling(self) -> MinMaxScaling:
        """Input scaling (physical → [-1, 1])."""
        return self._x_scaling

    @property
    def y_scaling(self) -> MinMaxScaling:
        """Output scaling (physical → [-1, 1])."""
        return self._y_scaling

    @property
    def scaling_set(self) -> bool:
        """Whether the scaling was set by `set_scaling`, `fit` or `load`."""
        return self._scaling_set

    # ------------------------------------------------------------------------------ weights
    # The training interface: what the training algorithms (levenberg_marquardt,
    # gradient_descent, training) use, all in scaled units: `theta`, `unpack`,
    # `forward_scaled`, `predict_scaled`, `mse_scaled` and `loss_gradient`.
    @property
    def theta(self) -> FloatArray:
        """The packed weights θ (n_params,): the network's own array, which trainers update
        in place (`get_params` returns a copy)."""
        return self._theta

    def unpack(self, theta: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Return views (Vt, Wt) of a packed vector: no copy.

        Parameters
        ----------
        theta : ndarray of shape (n_params,)

        Returns
        -------
        Vt : ndarray of shape (n_inputs + 1, n_hidden)
            Input weights V in rows 0..n_inputs-1, hidden biases c in the last row.
        Wt : ndarray of shape (n_outputs, n_hidden + 1)
            Output weights W in columns 0..n_hidden-1, output biases d in the last column.
        """
        split = self._n_hidden_params
        return (theta[:split].reshape(self._n_in + 1, self._n_hid),
                theta[split:].reshape(self._n_out, self._n_hid + 1))

    def get_params(self) -> FloatArray:
        """Return a copy of the packed weights θ, shape (n_params,)."""
        return self._theta.copy()

    def set_params(self, theta: npt.ArrayLike) -> None:
        """Copy packed weights θ of shape (n_params,) into the network."""
        theta = np.asarray(theta, dtype=np.float64)
        if theta.shape != self._theta.shape:
            raise ValueError(f'need {self.n_params} parameters, got shape {theta.shape}')
        if not np.all(np.isfinite(theta)):
            raise ValueError('parameters must be finite')
        np.copyto(self._theta, theta)

    def reset_momentum(self) -> None:
        """Forget the momentum of `partial_fit`; `fit` does it, `set_params` does not."""
        self._velocity.fill(0.0)

    def _initialise_weights(self) -> None:
        rng = np.random.default_rng(self._seed)
        kk, aa, bb = self._constants
        s = self._weight_scale
        n_in, n_hid = self._n_in, self._n_hid
        # z = x·V/a + (c − b)/a: draw the z-space weights, then map them to V and c.
        self._Vt[:n_in] = aa * rng.uniform(-s, s, (n_in, n_hid)) / math.sqrt(n_in)
        self._Vt[n_in] = bb + aa * rng.uniform(-s, s, n_hid)
        self._Wt[:, :n_hid] = rng.uniform(-1.0, 1.0, (self._n_out, n_hid)) / math.sqrt(n_hid)
        self._Wt[:, n_hid] = 0.0

    def set_step_units(self, inputs: Sequence[int], widths: Sequence[float]) -> None:
        """Start hidden units as steps of single inputs at 0, one per input and width.

        Unit ``u`` (0, 1, … in the order ``widths`` × ``inputs``) gets the net input
        z = 2·x_i / w of scaled input ``x_i`` alone (its other input weights 0, its bias
        ``b``), so that a sigmoid unit is k·σ(2·x_i / w) = k·(1 + tanh(x_i / w)) / 2: a
        step of half-width ``w`` (scaled units) at x_i = 0 (a SLOG or MSLOG unit, a
        wavelet, becomes a narrow wavelet there instead). The other units keep their
        random weights, the output weights are not changed; training moves these units
        like any other.

        It gives a sigmoid network the shape of a robot's Coulomb friction (each joint's
        effort jumps at zero speed) from the start. From random weights of ±weight_scale,
        LM needs input weights of several hundred to fit such a step, and grows them too
        slowly (``benchmarks/learning_curves.md``).

        Parameters
        ----------
        inputs : sequence of int
            Input columns (e.g. the joint velocities, n..2n−1 of [q, q', q'']).
        widths : sequence of float
            Half-widths, in scaled units (a fraction of the input's half-range), each > 0.

        Raises
        ------
        ValueError
            If an input is out of range, a width is not positive and finite, or there are
            more steps than hidden units.
        """
        inputs = [operator.index(i) for i in inputs]
        widths = [float(w) for w in widths]
        if any(not 0 <= i < self._n_in for i in inputs):
            raise ValueError(f'step inputs must be in [0, {self._n_in}), got {inputs}')
        if any(not (math.isfinite(w) and w > 0.0) for w in widths):
            raise ValueError(f'step widths must be positive, got {widths}')
        if len(inputs) * len(widths) > self._n_hid:
            raise ValueError(f'{len(widths)} step widths × {len(inputs)} inputs need more '
                             f'than the {self._n_hid} hidden units')
        a, b = self._constants.a, self._constants.b
        units = range(len(inputs) * len(widths))
        for unit, (width, column) in zip(units, itertools.product(widths, inputs)):
            self._Vt[:, unit] = 0.0
            self._Vt[column, unit] = 2.0 * a / width
            self._Vt[self._n_in, unit] = b

    # ------------------------------------------------------------------------------ scaling
    def set_scaling(self, x_min: npt.ArrayLike, x_max: npt.ArrayLike,
                    y_min: npt.ArrayLike, y_max: npt.ArrayLike) -> None:
        """Scale inputs and outputs from given physical ranges (e.g. the robot's limits).

        Parameters
        ----------
        x_min, x_max : array_like of shape (n_inputs,)
            Range of each input, mapped to [-1, 1].
        y_min, y_max : array_like of shape (n_outputs,)
            Range of each output, mapped to [-1, 1].
        """
        x_scaling = MinMaxScaling(np.asarray(x_min, float), np.asarray(x_max, float))
        y_scaling = MinMaxScaling(np.asarray(y_min, float), np.asarray(y_max, float))
        if x_scaling.n_features != self._n_in:
            raise ValueError(f'need {self._n_in} input ranges, got {x_scaling.n_features}')
        if y_scaling.n_features != self._n_out:
            raise ValueError(f'need {self._n_out} output ranges, got {y_scaling.n_features}')
        self._x_scaling, self._y_scaling = x_scaling, y_scaling
        self._scaling_set = True
        self._load_scaling_constants()
        self._step = self._online_step

    def _load_scaling_constants(self) -> None:
        # The hot path feeds x_t = [x_scaled, 1]/(2a) so that x_t·Vt is already the tanh
        # argument's variable part p/(2a): one multiplication less per sample.
        np.multiply(self._x_scaling.gain, self._form.scale, out=self._x_gain_t)
        np.multiply(self._x_scaling.offset, self._form.scale, out=self._x_offset_t)
        np.copyto(self._y_gain, self._y_scaling.gain)
        np.copyto(self._y_offset, self._y_scaling.offset)
        np.divide(1.0, self._y_scaling.gain, out=self._y_inv_gain)

    # ------------------------------------------------------------------------------ forward
    def forward_scaled(self, xs: FloatArray, theta: FloatArray | None = None, *,
                 derivative: bool = False) -> Layers:
        """Batched forward pass in scaled units.

        Parameters
        ----------
        xs : ndarray of shape (n, n_inputs)
            Scaled inputs.
        theta : ndarray of shape (n_params,), optional
            Weights to use instead of the network's.
        derivative : bool
            Also return g = dh/dp.

        Returns
        -------
        Layers
            h (n, n_hidden), g (n, n_hidden) or None, y (n, n_outputs).
        """
        Vt, Wt = self.unpack(self._theta if theta is None else theta)
        n_in, n_hid = self._n_in, self._n_hid
        p = xs @ Vt[:n_in]
        p += Vt[n_in]
        h, g = hidden_layer(p, self._form, derivative=derivative)
        y = h @ Wt[:, :n_hid].T
        y += Wt[:, n_hid]
        return Layers(h, g, y)

    def predict_scaled(self, xs: FloatArray, theta: FloatArray | None = None) -> FloatArray:
        """Scaled outputs (n, n_outputs) of scaled inputs (n, n_inputs), in bounded blocks."""
        if xs.shape[0] <= _DEFAULT_CHUNK:
            return self.forward_scaled(xs, theta).y
        out = np.empty((xs.shape[0], self._n_out))
        for start in range(0, xs.shape[0], _DEFAULT_CHUNK):
            stop = start + _DEFAULT_CHUNK
            out[start:stop] = self.forward_scaled(xs[start:stop], theta).y
        return out

    def mse_scaled(self, xs: FloatArray, ys: FloatArray,
                    theta: FloatArray | None = None) -> float:
        """Mean squared error over samples and outputs, in scaled units."""
        r = self.predict_scaled(xs, theta)
        r -= ys
        return float(np.vdot(r, r)) / r.size

    def loss_gradient(self, xs: FloatArray, ys: FloatArray,
                       theta: FloatArray | None = None) -> tuple[float, FloatArray]:
        """Back-propagation over a batch, in bounded blocks.

        Parameters
        ----------
        xs : ndarray of shape (n, n_inputs)
            Scaled inputs.
        ys : ndarray of shape (n, n_outputs)
            Scaled targets.
        theta : ndarray of shape (n_params,), optional
            Weights to use instead of the network's.

        Returns
        -------
        sse : float
            Sum of squared scaled errors over samples and outputs.
        gradient : ndarray of shape (n_params,)
            Gradient of L = sse / (2n), the mean over samples of ½·Σ_j e_j².
        """
        theta = self._theta if theta is None else theta
        W = self.unpack(theta)[1][:, :self._n_hid]
        grad = np.zeros(self.n_params)
        grad_V, grad_W = self.unpack(grad)
        n_in, n_hid = self._n_in, self._n_hid
        sse = 0.0
        for start in range(0, xs.shape[0], _DEFAULT_CHUNK):
            x_chunk = xs[start:start + _DEFAULT_CHUNK]
            layers = self.forward_scaled(x_chunk, theta, derivative=True)
            assert layers.g is not None
            r = layers.y - ys[start:start + _DEFAULT_CHUNK]
            sse += float(np.vdot(r, r))
            back = r @ W
            back *= layers.g
            grad_V[:n_in] += x_chunk.T @ back
            grad_V[n_in] += back.sum(axis=0)
            grad_W[:, :n_hid] += r.T @ layers.h
            grad_W[:, n_hid] += r.sum(axis=0)
        grad /= xs.shape[0]
        return sse, grad

    def predict(self, X: npt.ArrayLike) -> FloatArray:
        """Return the network's outputs in physical units.

        Parameters
        ----------
        X : array_like of shape (n_samples, n_inputs) or (n_inputs,)

        Returns
        -------
        ndarray of shape (n_samples, n_outputs) or (n_outputs,)
        """
        x = np.asarray(X, dtype=np.float64)
        if x.ndim == 1 and x.shape[0] == self._n_in:
            return self._predict_one(x)
        xs = self._check_inputs(x, 'X')
        return self._y_scaling.inverse_transform(self.predict_scaled(
            self._x_scaling.transform(xs)))

    def jacobian(self, X: npt.ArrayLike) -> FloatArray:
        """Return the Jacobian of the scaled outputs with respect to the packed weights.

        Parameters
        ----------
        X : array_like of shape (n_samples, n_inputs)
            Physical inputs.

        Returns
        -------
        ndarray of shape (n_samples·n_outputs, n_params)
            Row ``i·n_outputs + j`` is ∂y_scaled[i, j]/∂θ. Dense: for tests and
            comparisons; Levenberg–Marquardt never forms it.
        """
        xs = self._x_scaling.transform(self._check_inputs(np.asarray(X, float), 'X'))
        n, n_hid, n_out = xs.shape[0], self._n_hid, self._n_out
        layers = self.forward_scaled(xs, derivative=True)
        assert layers.g is not None
        W = self._Wt[:, :n_hid]
        xt = np.hstack([xs, np.ones((n, 1))])
        jac = np.zeros((n, n_out, self.n_params))
        # ∂y_j/∂Vt[i, h] = xt_i · W[j, h] · g_h
        hidden = xt[:, None, :, None] * (W[None, :, :] * layers.g[:, None, :])[:, :, None, :]
        jac[:, :, :self._n_hidden_params] = hidden.reshape(n, n_out, -1)
        ht = np.hstack([layers.h, np.ones((n, 1))])
        for j in range(n_out):  # ∂y_j/∂Wt[j, :] = [h, 1]
            start = self._n_hidden_params + j * (n_hid + 1)
            jac[:, j, start:start + n_hid + 1] = ht
        return jac.reshape(n * n_out, self.n_params)

    # ------------------------------------------------------------------------ online learning
    def partial_fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> FloatArray:
        """Learn online: one back-propagation step per sample, in order.

        Each step is stochastic gradient descent with momentum on the scaled squared error
        E = ½·Σ_j (y_j − ŷ_j)² of one sample (the paper's modified back-propagation)::

            v ← momentum·v − learning_rate·∂E/∂θ;   θ ← θ + v

        (PyTorch's ``SGD(momentum=…)`` without dampening makes the same steps.)

        Parameters
        ----------
        X : array_like of shape (n_samples, n_inputs) or (n_inputs,)
            Physical inputs.
        Y : array_like of shape (n_samples, n_outputs) or (n_outputs,)
            Physical targets.

        Returns
        -------
        ndarray of shape (n_samples, n_outputs) or (n_outputs,)
            A-priori errors Y − predict(X) in physical units, each taken just before its
            sample's step: the online identification error. ``Y − errors`` is the network's
            estimate.

        Raises
        ------
        RuntimeError
            If the scaling was never set (`set_scaling`, `fit` or `load`).
        ValueError
            On wrong shapes, or a sample whose step is not finite (the weights are then
            left as they were before that sample).
        """
        x = np.asarray(X, dtype=np.float64)
        y = np.asarray(Y, dtype=np.float64)
        if x.ndim == 1 and x.shape[0] == self._n_in and y.shape == (self._n_out,):
            return self._step(x, y)
        if x.shape == (1, self._n_in) and y.shape == (1, self._n_out):
            return self._step(x[0], y[0])[None, :]
        x = self._check_inputs(x, 'X')
        y = self._check_outputs(y, x.shape[0])
        errors = np.empty_like(y)
        step = self._step
        for i in range(x.shape[0]):
            errors[i] = step(x[i], y[i])
        return errors

    def _step_unscaled(self, x: FloatArray, y: FloatArray) -> FloatArray:
        raise RuntimeError('partial_fit needs the input and output scaling: call '
                           'set_scaling(x_min, x_max, y_min, y_max) with the physical '
                           'ranges (e.g. the robot limits) or fit(...) first')

    def _build_single_sample_path(self) -> tuple[Callable[[FloatArray], FloatArray],
                                                 Callable[[FloatArray, FloatArray], FloatArray]]:
        """Return ``predict_one(x)`` and ``step(x, y)`` for single samples.

        Preallocated buffers, no temporaries but the returned array. Buffers and weights are
        closed over as locals; everything they read is updated in place (weights, scaling
        constants), learning rate and momentum by rebuilding them.
        """
        n_in, n_hid, n_out = self._n_in, self._n_hid, self._n_out
        # The activation's TanhForm, not the reference functions of the table: those take
        # 39 µs for 40 units, 4× this whole prediction (~10 µs), too slow for 1 kHz.
        form = self._form
        n_terms = form.offset.shape[0]
        xt = np.empty(n_in + 1)  # [x_scaled, 1] / (2a)
        xt[n_in] = form.scale
        x_part, xt_col = xt[:n_in], xt[:, None]
        x_gain, x_offset = self._x_gain_t, self._x_offset_t
        y_gain, y_offset, y_inv_gain = self._y_gain, self._y_offset, self._y_inv_gain
        Vt, Wt = self._Vt, self._Wt
        W = Wt[:, :n_hid]
        p = np.empty(n_hid)
        t = np.empty((n_terms, n_hid))
        t_offset = form.offset
        ht = np.ones(n_hid + 1)  # [h, 1]
        h, ht_row = ht[:n_hid], ht[None, :]
        h_coef, h_const = form.h_coef, form.h_const
        # g scaled by 2a to make up for x_t = x/(2a) in the outer product below.
        g_coef, g_const = (form.g_coef * (2.0 * self._constants.a),
                           form.g_const * (2.0 * self._constants.a))
        y_hat = np.empty(n_out)
        e = np.empty(n_out)
        e_col = e[:, None]
        back = np.empty(n_hid)
        g = np.empty(n_hid)
        dz = np.empty(n_hid)
        grad, velocity, theta = self._grad, self._velocity, self._theta
        grad_V, grad_W = self.unpack(grad)
        lr, momentum = self._learning_rate, self._momentum
        multiply, add, subtract, dot, tanh = np.multiply, np.add, np.subtract, np.dot, np.tanh
        limit = math.inf

        def forward(x: FloatArray) -> None:
            multiply(x, x_gain, out=x_part)
            add(x_part, x_offset, out=x_part)
            dot(xt, Vt, out=p)  # p/(2a)
            add(p, t_offset, out=t)
            tanh(t, out=t)  # t_i = tanh((z + shift_i)/2), all terms in one call
            dot(h_coef, t, out=h)
            if h_const:
                add(h, h_const, out=h)
            dot(Wt, ht, out=y_hat)

        def predict_one(x: FloatArray) -> FloatArray:
            forward(x)
            y = subtract(y_hat, y_offset)
            return multiply(y, y_inv_gain, out=y)

        def step(x: FloatArray, y: FloatArray) -> FloatArray:
            forward(x)
            multiply(y, y_gain, out=e)
            add(e, y_offset, out=e)
            subtract(e, y_hat, out=e)  # scaled a-priori error
            error = multiply(e, y_inv_gain)  # physical, returned
            multiply(e, lr, out=e)
            multiply(e_col, ht_row, out=grad_W)  # lr·e ⊗ [h, 1]
            dot(e, W, out=back)
            multiply(t, t, out=t)
            dot(g_coef, t, out=g)
            if g_const:
                add(g, g_const, out=g)
            multiply(back, g, out=dz)
            multiply(xt_col, dz, out=grad_V)  # lr·[x, 1] ⊗ δ
            if not dot(grad, grad) < limit:
                raise ValueError(f'sample gives a non-finite step (x={x}, y={y}); skipped')
            multiply(velocity, momentum, out=velocity)
            add(velocity, grad, out=velocity)
            add(theta, velocity, out=theta)
            return error

        return predict_one, step

    # ----------------------------------------------------------------------- offline training
    def fit(self, X: npt.ArrayLike, Y: npt.ArrayLike, *, algorithm: str = 'lm',
            iterations: int = 315, goal: float = 0.0,
            validation: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
            max_fail: int = 6, min_iterations: int = 0,
            callback: Callback | None = None) -> FitHistory:
        """Train offline on a batch of samples.

        If the scaling was never set, it is first fitted to the minima and maxima of X and Y
        (later calls keep it). Training minimises the mean squared error of the scaled
        outputs (`FitHistory` explains the figures it records).

        Parameters
        ----------
        X : array_like of shape (n_samples, n_inputs)
            Physical inputs.
        Y : array_like of shape (n_samples, n_outputs)
            Physical targets.
        algorithm : {'lm', 'gd'}, default 'lm'
            Levenberg–Marquardt (like MATLAB's trainlm: mu from 1e-3, ×10 on failure, ÷10
            on success, stop above 1e10), or batch gradient descent with momentum (the
            paper's BP; uses `learning_rate` and `momentum` on the mean over samples of
            ½·Σ_j e_j²).
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

        Returns
        -------
        FitHistory
            Also resets the momentum of `partial_fit`.
        """
        from scara_ident_ros.nn.gradient_descent import GradientDescent
        from scara_ident_ros.nn.levenberg_marquardt import LevenbergMarquardt

        if algorithm not in ALGORITHMS:
            raise ValueError(f'algorithm {algorithm!r} is not one of {ALGORITHMS}')
        x = self._check_inputs(np.asarray(X, dtype=np.float64), 'X')
        y = self._check_outputs(np.asarray(Y, dtype=np.float64), x.shape[0])
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise ValueError('X and Y must be finite')
        iterations = operator.index(iterations)
        max_fail = operator.index(max_fail)
        min_iterations = operator.index(min_iterations)
        if iterations < 0 or max_fail < 1 or min_iterations < 0:
            raise ValueError('need iterations >= 0, max_fail >= 1 and min_iterations >= 0')
        if not self._scaling_set:
            xsc, ysc = MinMaxScaling.from_data(x), MinMaxScaling.from_data(y)
            self.set_scaling(xsc.lo, xsc.hi, ysc.lo, ysc.hi)
        xs, ys = self._x_scaling.transform(x), self._y_scaling.transform(y)
        val = None
        if validation is not None:
            xv = self._check_inputs(np.asarray(validation[0], dtype=np.float64), 'X_val')
            yv = self._check_outputs(np.asarray(validation[1], dtype=np.float64), xv.shape[0])
            val = (self._x_scaling.transform(xv), self._y_scaling.transform(yv))
        step = (LevenbergMarquardt(self, xs, ys) if algorithm == 'lm'
                else GradientDescent(self, xs, ys))
        history = run_training(self, algorithm, step, iterations=iterations, goal=float(goal),
                               validation=val, max_fail=max_fail,
                               min_iterations=min_iterations, callback=callback)
        self.reset_momentum()
        return history

    # ---------------------------------------------------------------------------- checking
    def _check_inputs(self, x: FloatArray, name: str) -> FloatArray:
        if x.ndim != 2 or x.shape[1] != self._n_in:
            raise ValueError(f'{name} must have shape (n_samples, {self._n_in}), '
                             f'got {x.shape}')
        return x

    def _check_outputs(self, y: FloatArray, n_samples: int) -> FloatArray:
        if y.ndim == 1 and n_samples == 1:
            y = y[None, :]
        if y.shape != (n_samples, self._n_out):
            raise ValueError(f'Y must have shape ({n_samples}, {self._n_out}), got {y.shape}')
        return y

    # --------------------------------------------------------------------------- save, load
    def save(self, path: str | Path) -> None:
        """Write the network to a portable ``.npz`` file (no pickle), atomically.

        The file holds the format version, sizes, activation and its constants, scaling,
        weights, the momentum state of `partial_fit`, training options, and `metadata`.

        Parameters
        ----------
        path : str or Path
            Written exactly as given (no suffix is added).
        """
        arrays: dict[str, np.ndarray] = {
            'sizes': np.array([self._n_in, self._n_hid, self._n_out], dtype=np.int64),
            'activation': np.array(self._activation),
            'constants': np.array(self._constants, dtype=np.float64),
            'params': self._theta.copy(),
            'velocity': self._velocity.copy(),
            'x_min': self._x_scaling.lo, 'x_max': self._x_scaling.hi,
            'y_min': self._y_scaling.lo, 'y_max': self._y_scaling.hi,
            'scaling_set': np.array(self._scaling_set),
            'training': np.array([self._learning_rate, self._momentum, self._weight_scale]),
            'seed': np.array(self._seed, dtype=np.int64),
        }
        write_model(path, arrays, self.metadata)

    @classmethod
    def load(cls, path: str | Path) -> FeedForwardNet:
        """Read a network written by `save`.

        Raises
        ------
        ModelFormatError
            If the file is not one of ours, of another format version, or corrupt.
        FileNotFoundError
            If there is no such file.
        """
        arrays, metadata = read_model(path)
        n_in, n_hid, n_out = (int(v) for v in arrays['sizes'])
        k, a, b = (float(v) for v in arrays['constants'])
        lr, momentum, weight_scale = (float(v) for v in arrays['training'])
        net = cls(n_in, n_hid, n_out, str(arrays['activation']), seed=int(arrays['seed']),
                  k=k, a=a, b=b, weight_scale=weight_scale, learning_rate=lr,
                  momentum=momentum)
        net.set_params(arrays['params'])
        np.copyto(net._velocity, arrays['velocity'])
        if bool(arrays['scaling_set']):
            net.set_scaling(arrays['x_min'], arrays['x_max'], arrays['y_min'], arrays['y_max'])
        net.metadata = metadata
        return net

    def __getstate__(self) -> dict[str, object]:
        """Picklable state (for a learner in another process): the single-sample path is a
        closure over buffers, rebuilt on unpickling."""
        state = self.__dict__.copy()
        state['_step'] = None if self._step is self._online_step else self._step
        del state['_predict_one'], state['_online_step']
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._predict_one, self._online_step = self._build_single_sample_path()
        if self._step is None:
            self._step = self._online_step

    def __repr__(self) -> str:
        k, a, b = self._constants
        return (f'FeedForwardNet({self._n_in}, {self._n_hid}, {self._n_out}, '
                f'{self._activation!r}, k={k:g}, a={a:g}, b={b:g}, seed={self._seed})')


def _check_rate(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f'{name} must be positive and finite, got {value}')
    return value


def _check_momentum(value: float) -> float:
    value = float(value)
    if not 0.0 <= value < 1.0:
        raise ValueError(f'momentum must be in [0, 1), got {value}')
    return value

