"""Batch computations of a `FeedForwardNet` in scaled units: what the training algorithms use.

Mean squared error, back-propagated gradient and the dense Jacobian of n samples at once,
over the network's forward pass (`network.forward_scaled`), in blocks of `CHUNK` samples
(bounded memory). Each takes an optional packed weight vector θ to evaluate instead of the
network's own (a trial step).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from scara_ident_ros.nn.network import CHUNK, FeedForwardNet, forward_scaled, predict_scaled

__all__ = ['jacobian', 'loss_gradient', 'mse_scaled']

FloatArray = npt.NDArray[np.float64]


def mse_scaled(net: FeedForwardNet, xs: FloatArray, ys: FloatArray,
               theta: FloatArray | None = None) -> float:
    """Mean squared error over samples and outputs, in scaled units."""
    r = predict_scaled(net, xs, theta)
    r -= ys
    return float(np.vdot(r, r)) / r.size


def loss_gradient(net: FeedForwardNet, xs: FloatArray, ys: FloatArray,
                  theta: FloatArray | None = None) -> tuple[float, FloatArray]:
    """Back-propagation over scaled inputs ``xs`` (n, n_inputs) and targets ``ys``
    (n, n_outputs): the sum of squared errors over samples and outputs, and the gradient
    (n_params,) of L = sse / (2n), the mean over samples of ½·Σ_j e_j²."""
    theta = net.theta if theta is None else theta
    n_in, n_hid = net.n_inputs, net.n_hidden
    W = net.unpack(theta)[1][:, :n_hid]
    grad = np.zeros(net.n_params)
    grad_V, grad_W = net.unpack(grad)
    sse = 0.0
    for start in range(0, xs.shape[0], CHUNK):
        x_chunk = xs[start:start + CHUNK]
        layers = forward_scaled(net, x_chunk, theta, derivative=True)
        assert layers.g is not None
        r = layers.y - ys[start:start + CHUNK]
        sse += float(np.vdot(r, r))
        back = r @ W
        back *= layers.g
        grad_V[:n_in] += x_chunk.T @ back
        grad_V[n_in] += back.sum(axis=0)
        grad_W[:, :n_hid] += r.T @ layers.h
        grad_W[:, n_hid] += r.sum(axis=0)
    grad /= xs.shape[0]
    return sse, grad


def jacobian(net: FeedForwardNet, X: npt.ArrayLike) -> FloatArray:
    """The Jacobian (n_samples·n_outputs, n_params) of the scaled outputs with respect to
    the packed weights at physical inputs ``X`` (n_samples, n_inputs): row
    ``i·n_outputs + j`` is ∂y_scaled[i, j]/∂θ. Dense: for tests and comparisons;
    Levenberg–Marquardt never forms it."""
    xs = net.x_scaling.transform(net.check_inputs(np.asarray(X, float), 'X'))
    n, n_hid, n_out = xs.shape[0], net.n_hidden, net.n_outputs
    n_hidden_params = (net.n_inputs + 1) * n_hid
    layers = forward_scaled(net, xs, derivative=True)
    assert layers.g is not None
    W = net.unpack(net.theta)[1][:, :n_hid]
    xt = np.hstack([xs, np.ones((n, 1))])
    jac = np.zeros((n, n_out, net.n_params))
    # ∂y_j/∂Vt[i, h] = xt_i · W[j, h] · g_h
    hidden = xt[:, None, :, None] * (W[None, :, :] * layers.g[:, None, :])[:, :, None, :]
    jac[:, :, :n_hidden_params] = hidden.reshape(n, n_out, -1)
    ht = np.hstack([layers.h, np.ones((n, 1))])
    for j in range(n_out):  # ∂y_j/∂Wt[j, :] = [h, 1]
        start = n_hidden_params + j * (n_hid + 1)
        jac[:, j, start:start + n_hid + 1] = ht
    return jac.reshape(n * n_out, net.n_params)
