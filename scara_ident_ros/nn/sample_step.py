"""The per-sample path of a `FeedForwardNet`: one prediction, one online gradient step.

`FeedForwardNet.predict` of one sample and `FeedForwardNet.partial_fit` run these closures
at the rate of a joint-state stream, so they allocate nothing but the returned array: every
buffer, the weights and the scaling constants are closed over and updated in place (the
network rebuilds the closures when its learning rate or momentum changes).

One step is stochastic gradient descent with momentum on the scaled squared error
E = ½·Σ_j (y_j − ŷ_j)² of one sample (the paper's modified back-propagation)::

    v ← momentum·v − learning_rate·∂E/∂θ;   θ ← θ + v
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np
import numpy.typing as npt

from scara_ident_ros.nn.activations import TanhForm

__all__ = ['HotScaling', 'build_sample_path']

FloatArray = npt.NDArray[np.float64]
Predict = Callable[[FloatArray], FloatArray]
Step = Callable[[FloatArray, FloatArray], FloatArray]


class HotScaling(NamedTuple):
    """Scaling constants, updated in place by `FeedForwardNet.set_scaling`; the inputs'
    gain and offset times 1/(2a), so that [x_scaled, 1]/(2a)·Vt is the tanh argument."""

    x_gain: FloatArray  # (n_inputs,)
    x_offset: FloatArray  # (n_inputs,)
    y_gain: FloatArray  # (n_outputs,)
    y_offset: FloatArray  # (n_outputs,)
    y_inv_gain: FloatArray  # (n_outputs,)


def build_sample_path(form: TanhForm, a: float, Vt: FloatArray, Wt: FloatArray,
                      scaling: HotScaling, *, theta: FloatArray, velocity: FloatArray,
                      grad: FloatArray, learning_rate: float,
                      momentum: float) -> tuple[Predict, Step]:
    """Return ``predict_one(x)`` and ``step(x, y)`` for single physical samples.

    ``Vt`` (n_inputs + 1, n_hidden) and ``Wt`` (n_outputs, n_hidden + 1) are the views of
    the packed weights ``theta`` (`FeedForwardNet.unpack`); ``theta``, ``velocity`` (the
    momentum) and ``grad`` (the step's buffer), all (n_params,), are updated in place.

    Returns
    -------
    predict_one : callable
        x (n_inputs,) → ŷ (n_outputs,), physical units.
    step : callable
        (x, y) → a-priori error y − ŷ (n_outputs,) in physical units, then one step.
        Raises ValueError, weights untouched, if the step is not finite.
    """
    n_in, n_hid = Vt.shape[0] - 1, Vt.shape[1]
    n_out = Wt.shape[0]
    # The activation's TanhForm, not the reference functions of the table: those are
    # several times slower than this whole prediction.
    n_terms = form.offset.shape[0]
    xt = np.empty(n_in + 1)  # [x_scaled, 1] / (2a)
    xt[n_in] = form.scale
    x_part, xt_col = xt[:n_in], xt[:, None]
    x_gain, x_offset, y_gain, y_offset, y_inv_gain = scaling
    W = Wt[:, :n_hid]
    p = np.empty(n_hid)
    t = np.empty((n_terms, n_hid))
    t_offset = form.offset
    ht = np.ones(n_hid + 1)  # [h, 1]
    h, ht_row = ht[:n_hid], ht[None, :]
    h_coef, h_const = form.h_coef, form.h_const
    # g scaled by 2a to make up for x_t = x/(2a) in the outer product below.
    g_coef, g_const = form.g_coef * (2.0 * a), form.g_const * (2.0 * a)
    y_hat = np.empty(n_out)
    e = np.empty(n_out)
    e_col = e[:, None]
    back = np.empty(n_hid)
    g = np.empty(n_hid)
    dz = np.empty(n_hid)
    grad_V, grad_W = grad[:Vt.size].reshape(Vt.shape), grad[Vt.size:].reshape(Wt.shape)
    lr = learning_rate
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
