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
The batch forward pass in scaled units (`forward_scaled`, `predict_scaled`) is here, with the
model; what training needs of a batch (MSE, gradient, Jacobian) is in `batch`, the
per-sample path of `predict` and `partial_fit` in `sample_step`, offline training in
`fitting` (``fit(net, X, Y)``, which `FeedForwardNet.fit` calls), friction-step
initialisation in `friction_steps`. They build on the model: imported here only inside the
methods that call them.

The network keeps the estimator contract (:mod:`scara_ident_ros.estimator`): ``fit``,
``partial_fit``, ``predict``, ``score``, ``get_params``, ``save``/``load``, kind ``'network'``.
"""
from __future__ import annotations

import math
import operator
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import numpy.typing as npt

from scara_ident_ros.estimator import r2_score, register_kind
from scara_ident_ros.nn.activations import (ACTIVATIONS, DEFAULT_CONSTANTS,
                                            ActivationConstants, TanhForm, hidden_layer,
                                            tanh_form)
from scara_ident_ros.nn.model_file import read_model, write_model
from scara_ident_ros.nn.sample_step import HotScaling, build_sample_path
from scara_ident_ros.nn.scaling import MinMaxScaling

if TYPE_CHECKING:
    from scara_ident_ros.nn.training import Callback, FitHistory

__all__ = ['CHUNK', 'FeedForwardNet', 'Layers', 'forward_scaled', 'predict_scaled']

FloatArray = npt.NDArray[np.float64]

CHUNK = 1024  # samples per block in batched computations (bounds memory)


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

    Attributes
    ----------
    metadata : dict of str to ndarray
        Saved with the network (``joint_names``, ``method``, ...).
    history_ : FitHistory or None
        The training of the last `fit`.

    Notes
    -----
    Before `set_scaling` or `fit`, inputs and outputs are taken as already scaled
    (identity scaling), `predict` works, and `partial_fit` refuses to learn.

    Not thread-safe: single-sample `predict` and `partial_fit` share preallocated buffers.
    Call one network from one thread at a time (a ROS callback group that is mutually
    exclusive does that).
    """

    #: The model file's kind (:func:`scara_ident_ros.estimator.load_model`).
    kind = 'network'

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
        self.history_: FitHistory | None = None

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
        # Scaling constants of the per-sample path, updated in place by set_scaling.
        self._hot = HotScaling(np.empty(n_in), np.empty(n_in), np.empty(n_out),
                               np.empty(n_out), np.empty(n_out))
        self._load_scaling_constants()
        self._build_single_sample_path()

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
    def form(self) -> TanhForm:
        """The activation with its constants, as the network evaluates it."""
        return self._form

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
        self._build_single_sample_path()

    @property
    def momentum(self) -> float:
        """Momentum of `partial_fit` and of batch gradient descent, in [0, 1)."""
        return self._momentum

    @momentum.setter
    def momentum(self, value: float) -> None:
        self._momentum = _check_momentum(value)
        self._build_single_sample_path()

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

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joints of the outputs, as recorded in `metadata`, or None if not recorded."""
        names = self.metadata.get('joint_names')
        return None if names is None else tuple(str(name) for name in np.atleast_1d(names))

    @property
    def method(self) -> str:
        """The method key (``'ffs'``, ...): ``metadata['method']`` if it names one, else
        the method of the activation (or the activation's name)."""
        from scara_ident_ros.nn.presets import METHODS

        method = self.metadata.get('method')
        if method is not None and str(method) in METHODS:
            return str(method)
        for key, spec in METHODS.items():
            if spec.activation == self._activation:
                return key
        return self._activation

    def get_params(self) -> dict[str, Any]:
        """The hyperparameters given to the constructor (sizes, activation and its
        constants, seed, weight scale, learning rate, momentum), as data."""
        k, a, b = self._constants
        return {'n_inputs': self._n_in, 'n_hidden': self._n_hid, 'n_outputs': self._n_out,
                'activation': self._activation, 'seed': self._seed, 'k': k, 'a': a, 'b': b,
                'weight_scale': self._weight_scale, 'learning_rate': self._learning_rate,
                'momentum': self._momentum}

    # ------------------------------------------------------------------------------ weights
    # What the training algorithms and `batch` use, in scaled units: `theta`, `unpack`.
    @property
    def theta(self) -> FloatArray:
        """The packed weights θ (n_params,): the network's own array, which trainers update
        in place (`get_theta` returns a copy; `get_params` returns the hyperparameters)."""
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

    def get_theta(self) -> FloatArray:
        """Return a copy of the packed weights θ, shape (n_params,)."""
        return self._theta.copy()

    def set_theta(self, theta: npt.ArrayLike) -> None:
        """Copy packed weights θ of shape (n_params,) into the network."""
        theta = np.asarray(theta, dtype=np.float64)
        if theta.shape != self._theta.shape:
            raise ValueError(f'need {self.n_params} parameters, got shape {theta.shape}')
        if not np.all(np.isfinite(theta)):
            raise ValueError('parameters must be finite')
        np.copyto(self._theta, theta)

    def reset_momentum(self) -> None:
        """Forget the momentum of `partial_fit`; `fit` does it, `set_theta` does not."""
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
        hot = self._hot
        np.multiply(self._x_scaling.gain, self._form.scale, out=hot.x_gain)
        np.multiply(self._x_scaling.offset, self._form.scale, out=hot.x_offset)
        np.copyto(hot.y_gain, self._y_scaling.gain)
        np.copyto(hot.y_offset, self._y_scaling.offset)
        np.divide(1.0, self._y_scaling.gain, out=hot.y_inv_gain)

    # ------------------------------------------------------------------------------ predict
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
        xs = self.check_inputs(x, 'X')
        return self._y_scaling.inverse_transform(predict_scaled(
            self, self._x_scaling.transform(xs)))

    def score(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> float:
        """R² of the predictions of Y (N, n_outputs) from X (N, n_inputs): 1 − mean NMSE
        over the outputs (:func:`scara_ident_ros.estimator.r2_score`)."""
        return r2_score(Y, self.predict(X))

    # ------------------------------------------------------------------------ offline learning
    def fit(self, X: npt.ArrayLike, Y: npt.ArrayLike, *,
            validation: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
            validation_fraction: float | None = None, samples: int | None = None,
            algorithm: str = 'lm', iterations: int | None = None, goal: float = 0.0,
            max_fail: int | None = None, min_iterations: int | None = None,
            callback: Callback | None = None, weight_decay: float = 0.0) -> FeedForwardNet:
        """Train offline with the project's defaults (``scara-ident train``'s), in place.

        `fitting.train_offline`: blocks of consecutive rows validate (or ``validation``),
        Levenberg–Marquardt on at most 8000 samples of the others, stopped after 50
        iterations without a new best validation error (counted from iteration 50, at most
        500) with the best weights kept. Draws use the network's `seed`. If the scaling
        was never set, it is fitted to the ranges of X and Y.

        Parameters
        ----------
        X : array_like of shape (n_samples, n_inputs)
            Physical inputs, rows in time order.
        Y : array_like of shape (n_samples, n_outputs)
            Physical targets.
        validation, validation_fraction, samples : optional
            `fitting.train_offline`'s; None takes its default.
        algorithm, iterations, goal, max_fail, min_iterations, callback : optional
            `fitting.fit`'s; None takes `fitting.train_offline`'s default.
        weight_decay : float, default 0.0
            `fitting.fit`'s L2 penalty λ on the weights (0: none).

        Returns
        -------
        FeedForwardNet
            ``self``, its training in `history_`.
        """
        from scara_ident_ros.nn.fitting import train_offline

        options: dict[str, Any] = {
            'validation_fraction': validation_fraction, 'samples': samples,
            'iterations': iterations, 'max_fail': max_fail, 'min_iterations': min_iterations}
        self.history_ = train_offline(
            self, X, Y, validation=validation, seed=self._seed, algorithm=algorithm,
            goal=goal, callback=callback, weight_decay=weight_decay,
            **{key: value for key, value in options.items() if value is not None})
        return self

    # ------------------------------------------------------------------------ online learning
    def partial_fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> FloatArray:
        """Learn online: one back-propagation step per sample, in order.

        Each step is stochastic gradient descent with momentum on the scaled squared error
        of one sample (`sample_step`; PyTorch's ``SGD(momentum=…)`` without dampening makes
        the same steps).

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
        x = self.check_inputs(x, 'X')
        y = self.check_outputs(y, x.shape[0])
        errors = np.empty_like(y)
        step = self._step
        for i in range(x.shape[0]):
            errors[i] = step(x[i], y[i])
        return errors

    def _step_unscaled(self, x: FloatArray, y: FloatArray) -> FloatArray:
        raise RuntimeError('partial_fit needs the input and output scaling: call '
                           'set_scaling(x_min, x_max, y_min, y_max) with the physical '
                           'ranges (e.g. the robot limits) or fit(X, Y) first')

    def _build_single_sample_path(self) -> None:
        """(Re)build the per-sample closures over the buffers and the training options;
        `partial_fit` steps through them once the scaling is set."""
        self._predict_one, self._online_step = build_sample_path(
            self._form, self._constants.a, self._Vt, self._Wt, self._hot, theta=self._theta,
            velocity=self._velocity, grad=self._grad,
            learning_rate=self._learning_rate, momentum=self._momentum)
        self._step = self._online_step if self._scaling_set else self._step_unscaled

    # ---------------------------------------------------------------------------- checking
    def check_inputs(self, x: FloatArray, name: str) -> FloatArray:
        """Return inputs ``x`` (n_samples, n_inputs), or raise ValueError naming ``name``."""
        if x.ndim != 2 or x.shape[1] != self._n_in:
            raise ValueError(f'{name} must have shape (n_samples, {self._n_in}), '
                             f'got {x.shape}')
        return x

    def check_outputs(self, y: FloatArray, n_samples: int) -> FloatArray:
        """Return targets (n_samples, n_outputs), a single row (n_outputs,) made 2-D."""
        if y.ndim == 1 and n_samples == 1:
            y = y[None, :]
        if y.shape != (n_samples, self._n_out):
            raise ValueError(f'Y must have shape ({n_samples}, {self._n_out}), got {y.shape}')
        return y

    # --------------------------------------------------------------------------- save, load
    def to_arrays(self) -> dict[str, np.ndarray]:
        """The network's entries of the model file (`model_file`'s table), no metadata."""
        return {
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

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> FeedForwardNet:
        """Rebuild a network from `to_arrays`' entries, as `model_file` validated them."""
        n_in, n_hid, n_out = (int(v) for v in arrays['sizes'])
        k, a, b = (float(v) for v in arrays['constants'])
        lr, momentum, weight_scale = (float(v) for v in arrays['training'])
        net = cls(n_in, n_hid, n_out, str(arrays['activation']), seed=int(arrays['seed']),
                  k=k, a=a, b=b, weight_scale=weight_scale, learning_rate=lr,
                  momentum=momentum)
        net.set_theta(arrays['params'])
        np.copyto(net._velocity, arrays['velocity'])
        if bool(arrays['scaling_set']):
            net.set_scaling(arrays['x_min'], arrays['x_max'], arrays['y_min'], arrays['y_max'])
        return net

    def save(self, path: str | Path) -> None:
        """Write the network to a portable ``.npz`` file (no pickle), atomically.

        The file holds the format version, sizes, activation and its constants, scaling,
        weights, the momentum state of `partial_fit`, training options, and `metadata`.

        Parameters
        ----------
        path : str or Path
            Written exactly as given (no suffix is added).
        """
        write_model(path, self.to_arrays(), self.metadata)

    @classmethod
    def load(cls, path: str | Path) -> FeedForwardNet:
        """Read a network written by `save`.

        Raises
        ------
        ModelFormatError
            If the file is not one of ours, of another format version, corrupt, or a model
            of another kind (physical, hybrid).
        FileNotFoundError
            If there is no such file.
        """
        arrays, metadata = read_model(path)
        net = cls.from_arrays(arrays)
        net.metadata = metadata
        return net

    def __getstate__(self) -> dict[str, object]:
        """Picklable state (for a learner in another process): the single-sample path is a
        closure over buffers, rebuilt on unpickling."""
        state = self.__dict__.copy()
        del state['_predict_one'], state['_online_step'], state['_step']
        del state['_Vt'], state['_Wt']  # views of θ: pickled, they would become copies
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._Vt, self._Wt = self.unpack(self._theta)
        self._build_single_sample_path()

    def __repr__(self) -> str:
        k, a, b = self._constants
        return (f'FeedForwardNet({self._n_in}, {self._n_hid}, {self._n_out}, '
                f'{self._activation!r}, k={k:g}, a={a:g}, b={b:g}, seed={self._seed})')


register_kind(FeedForwardNet.kind, FeedForwardNet.load)


class Layers(NamedTuple):
    """Batched forward pass in scaled units, for n samples (`forward_scaled`)."""

    h: FloatArray  # (n, n_hidden) hidden outputs
    g: FloatArray | None  # (n, n_hidden) dh/d(x·v + c) = k·f'(z)/a, if asked for
    y: FloatArray  # (n, n_outputs) scaled outputs


def forward_scaled(net: FeedForwardNet, xs: FloatArray, theta: FloatArray | None = None, *,
                   derivative: bool = False) -> Layers:
    """The `Layers` of scaled inputs ``xs`` (n, n_inputs) at the network's weights, or at
    packed weights ``theta`` (n_params,) instead (a trial step); g = dh/dp only if
    ``derivative``."""
    Vt, Wt = net.unpack(net.theta if theta is None else theta)
    n_in, n_hid = net.n_inputs, net.n_hidden
    p = xs @ Vt[:n_in]
    p += Vt[n_in]
    h, g = hidden_layer(p, net.form, derivative=derivative)
    y = h @ Wt[:, :n_hid].T
    y += Wt[:, n_hid]
    return Layers(h, g, y)


def predict_scaled(net: FeedForwardNet, xs: FloatArray,
                   theta: FloatArray | None = None) -> FloatArray:
    """Scaled outputs (n, n_outputs) of scaled inputs (n, n_inputs), in blocks of `CHUNK`
    samples (bounded memory)."""
    if xs.shape[0] <= CHUNK:
        return forward_scaled(net, xs, theta).y
    out = np.empty((xs.shape[0], net.n_outputs))
    for start in range(0, xs.shape[0], CHUNK):
        out[start:start + CHUNK] = forward_scaled(net, xs[start:start + CHUNK], theta).y
    return out


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

