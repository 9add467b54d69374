"""Levenberg–Marquardt training, like MATLAB's ``trainlm``, with structured normal equations.

Each iteration solves (JᵀJ + μI)·δ = Jᵀr by Cholesky and tries θ − δ, where r are the scaled
output errors (ŷ − y) of all samples and J = ∂r/∂θ. A step that lowers the sum of squared
errors is taken and μ divided by 10; otherwise (or if the Cholesky factorisation fails) μ is
multiplied by 10 and the step recomputed; training stops when μ exceeds ``mu_max``.

J (n_samples·n_outputs × n_params) is never formed. For sample n and output j, with
x̃ = [x, 1], h̃ = [h, 1] and g = dh/dp of the hidden units,

    ∂r_nj/∂Vt[i, h] = x̃_ni · g_nh · W_jh = Z_n,(i,h) · W_jh,   Z_n,(i,h) = x̃_ni · g_nh
    ∂r_nj/∂Wt[j', h] = δ_jj' · h̃_nh

so the blocks of JᵀJ are, summed over samples,

    hidden–hidden   (ZᵀZ) ∘ (1 ⊗ WᵀW)           one (n, (n_in+1)·H) product instead of
                                                 n_outputs of them
    hidden–output   (Zᵀh̃) ∘ W, per output j
    output–output   I ⊗ (h̃ᵀh̃)                   block diagonal: one (H+1)² block

and Jᵀr is ordinary back-propagation. Samples are processed in chunks, so memory is bounded
by the chunk size, not by n_samples.

The Cholesky factor comes from ``np.linalg.cholesky``, not ``scipy.linalg.cho_factor``:
numpy and scipy wheels each bundle their own OpenBLAS, and on a small machine the idle
threads of one pool spin against the working threads of the other, which made the same
factorisation and the following products 10–50× slower at random. Keeping every O(n³) and
O(N·n²) operation in numpy's BLAS avoids that; scipy only does the O(n²) triangular solves.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from scipy.linalg import cho_solve

from scara_ident_ros.nn.training import STOP_MU_MAX, FitHistory, StopTraining

if TYPE_CHECKING:
    from scara_ident_ros.nn.network import FeedForwardNet

__all__ = ['LevenbergMarquardt', 'normal_equations']

FloatArray = npt.NDArray[np.float64]


def normal_equations(net: FeedForwardNet, xs: FloatArray, ys: FloatArray, *,
                     chunk_size: int = 1024, out: tuple[FloatArray, FloatArray] | None = None,
                     single: bool = False) -> tuple[FloatArray, FloatArray, float]:
    """Return JᵀJ, Jᵀr and the sum of squared errors at the network's weights.

    Parameters
    ----------
    net : FeedForwardNet
    xs : ndarray of shape (n_samples, n_inputs)
        Scaled inputs.
    ys : ndarray of shape (n_samples, n_outputs)
        Scaled targets.
    chunk_size : int, default 1024
        Samples per block; memory use is about chunk_size·(n_inputs + 1)·n_hidden floats.
    out : (ndarray (n_params, n_params), ndarray (n_params,)), optional
        Buffers to fill instead of allocating.
    single : bool, default False
        Accumulate the hidden-layer blocks of JᵀJ (the O(n·((n_in+1)·H)²) products, most of
        the cost) in float32: 2.3× faster products, entries to ~1e-6 relative. Jᵀr, the
        error and the step's acceptance stay in float64, so a step is only taken if it
        lowers the float64 error; LM's damping absorbs the rest.

    Returns
    -------
    jtj : ndarray of shape (n_params, n_params)
        JᵀJ, symmetric, J = ∂(ŷ − y)/∂θ of the scaled outputs.
    jtr : ndarray of shape (n_params,)
        Jᵀr, r = ŷ − y.
    sse : float
        Σ r².
    """
    n_in, n_hid, n_out = net.n_inputs, net.n_hidden, net.n_outputs
    n_params = net.n_params
    n_h = (n_in + 1) * n_hid  # hidden-layer parameters come first in θ
    jtj, jtr = out if out is not None else (np.empty((n_params, n_params)),
                                            np.empty(n_params))
    jtr.fill(0.0)
    jtr_V, jtr_W = net.unpack(jtr)
    W = net.unpack(net.theta)[1][:, :n_hid]
    chunk = min(chunk_size, xs.shape[0])
    wide = np.float32 if single else np.float64  # type of the hidden-layer products
    xt = np.ones((chunk, n_in + 1))
    ht = np.ones((chunk, n_hid + 1))
    z = np.empty((chunk, n_in + 1, n_hid), dtype=wide)
    ztz = np.zeros((n_h, n_h), dtype=wide)
    zht = np.zeros((n_h, n_hid + 1), dtype=wide)
    hth = np.zeros((n_hid + 1, n_hid + 1))
    sse = 0.0
    for start in range(0, xs.shape[0], chunk):
        x_chunk = xs[start:start + chunk]
        n = x_chunk.shape[0]
        layers = net.forward_scaled(x_chunk, derivative=True)
        g = layers.g
        assert g is not None
        r = layers.y
        r -= ys[start:start + chunk]
        sse += float(np.vdot(r, r))
        xt[:n, :n_in] = x_chunk
        ht[:n, :n_hid] = layers.h
        np.multiply(xt[:n, :, None], g[:, None, :], out=z[:n])
        z_flat = z[:n].reshape(n, n_h)
        ztz += z_flat.T @ z_flat  # numpy hands Aᵀ·A to BLAS syrk
        zht += z_flat.T @ ht[:n].astype(wide, copy=False)
        hth += ht[:n].T @ ht[:n]
        back = r @ W
        back *= g
        jtr_V += xt[:n].T @ back
        jtr_W += r.T @ ht[:n]
    B = W.T @ W
    ztz, zht = ztz.astype(np.float64, copy=False), zht.astype(np.float64, copy=False)
    jtj[:n_h, :n_h] = (ztz.reshape(n_in + 1, n_hid, n_in + 1, n_hid)
                       * B[None, :, None, :]).reshape(n_h, n_h)
    cross = (zht.reshape(n_in + 1, n_hid, 1, n_hid + 1)
             * W.T[None, :, :, None]).reshape(n_h, n_out * (n_hid + 1))
    jtj[:n_h, n_h:] = cross
    jtj[n_h:, :n_h] = cross.T
    jtj[n_h:, n_h:] = 0.0
    for j in range(n_out):
        block = slice(n_h + j * (n_hid + 1), n_h + (j + 1) * (n_hid + 1))
        jtj[block, block] = hth
    return jtj, jtr, sse


class LevenbergMarquardt:
    """A `training.TrainingStep` doing Levenberg–Marquardt (module docstring).

    Parameters
    ----------
    net : FeedForwardNet
        Network to train, in place.
    xs : ndarray of shape (n_samples, n_inputs)
        Scaled inputs.
    ys : ndarray of shape (n_samples, n_outputs)
        Scaled targets.
    mu : float, default 1e-3
        Initial damping.
    mu_decrease, mu_increase : float, default 0.1 and 10
        Factors applied to mu after a successful and a failed step.
    mu_max : float, default 1e10
        Training stops when mu exceeds it.
    chunk_size : int, default 1024
        Samples per block when assembling the normal equations.
    single : bool, default False
        Assemble JᵀJ's hidden-layer blocks in float32 (see `normal_equations`).
    """

    def __init__(self, net: FeedForwardNet, xs: FloatArray, ys: FloatArray, *,
                 mu: float = 1e-3, mu_decrease: float = 0.1, mu_increase: float = 10.0,
                 mu_max: float = 1e10, chunk_size: int = 1024, single: bool = False) -> None:
        if not (mu > 0.0 and 0.0 < mu_decrease < 1.0 < mu_increase and mu_max >= mu):
            raise ValueError('need mu > 0, 0 < mu_decrease < 1 < mu_increase, mu_max >= mu')
        self._net, self._xs, self._ys = net, xs, ys
        self.mu = mu
        self._mu_decrease, self._mu_increase, self._mu_max = mu_decrease, mu_increase, mu_max
        self._chunk_size = chunk_size
        self._single = single
        n_params = net.n_params
        self._jtj = np.empty((n_params, n_params))
        self._jtr = np.empty(n_params)
        self._work = np.empty((n_params, n_params))
        self._diagonal = self._work.reshape(-1)[::n_params + 1]  # a view
        self._trial = np.empty(n_params)
        self._sse = np.inf
        self._stale = True  # normal equations not assembled at the current weights
        self._history: FitHistory | None = None

    def start(self, history: FitHistory) -> float:
        """Keep ``history`` for the damping log; return the current training MSE."""
        self._history = history
        return self.set_data(self._xs, self._ys)

    def set_data(self, xs: FloatArray, ys: FloatArray) -> float:
        """Train on other samples from now on (keeping mu); return their current MSE.

        For learning beside a stream, where the samples (a reservoir) change between steps.

        Parameters
        ----------
        xs : ndarray of shape (n_samples, n_inputs)
            Scaled inputs.
        ys : ndarray of shape (n_samples, n_outputs)
            Scaled targets.
        """
        self._xs, self._ys = xs, ys
        self._sse = self._net.mse_scaled(xs, ys) * ys.size
        self._stale = True
        return self._sse / ys.size

    def step(self) -> float:
        """Make one successful step; return the training MSE after it.

        Raises
        ------
        StopTraining
            'mu_max' when no damping up to mu_max lowers the error.
        """
        net = self._net
        if self._stale:
            normal_equations(net, self._xs, self._ys, chunk_size=self._chunk_size,
                             out=(self._jtj, self._jtr), single=self._single)
            self._stale = False
        while self.mu <= self._mu_max:
            np.copyto(self._work, self._jtj)
            self._diagonal += self.mu
            try:
                lower = np.linalg.cholesky(self._work)
            except np.linalg.LinAlgError:  # not positive definite at this damping
                self.mu *= self._mu_increase
                continue
            delta = cho_solve((lower, True), self._jtr, check_finite=False)
            np.subtract(net.theta, delta, out=self._trial)
            sse = net.mse_scaled(self._xs, self._ys, self._trial) * self._ys.size
            if sse < self._sse:
                np.copyto(net.theta, self._trial)
                self._sse = sse
                self._stale = True
                if self._history is not None:
                    self._history.mu.append(self.mu)
                self.mu *= self._mu_decrease
                return sse / self._ys.size
            self.mu *= self._mu_increase
        raise StopTraining(STOP_MU_MAX)
