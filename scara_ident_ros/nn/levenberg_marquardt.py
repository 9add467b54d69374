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

The damped system is solved on those blocks too (:class:`NormalBlocks`), not on the whole
n_params × n_params matrix: with K = h̃ᵀh̃ + μI, the output weights' block I ⊗ K is
eliminated (one (H+1)² Cholesky for every output), and the Schur complement on the hidden
weights is again a Hadamard product,

    S = (ZᵀZ − (Zᵀh̃) K⁻¹ (Zᵀh̃)ᵀ) ∘ (1 ⊗ WᵀW) + μI      ((n_in+1)·H square)

since output j's cross block is (Zᵀh̃) scaled by W_j row-wise and Σ_j W_jᵀW_j = WᵀW. One
Cholesky of S, then back-substitution for each output's weights: the same step as the
plain normal equations to rounding, at (n_h / n_params)³ of the factorisation's cost
(n_h = (n_in+1)·H: 0.45 for a 4-joint 12-40-4 network, 0.42 for a 7-joint 21-40-7 one).

The Cholesky factor comes from ``np.linalg.cholesky``, not ``scipy.linalg.cho_factor``:
numpy and scipy wheels each bundle their own OpenBLAS, and on a small machine the idle
threads of one pool spin against the working threads of the other, which made the same
factorisation and the following products many times slower at random. Keeping every O(n³) and
O(N·n²) operation in numpy's BLAS avoids that; scipy only does the O(n²) triangular solves.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.linalg import cho_solve, solve_triangular

from scara_ident_ros.nn.batch import mse_scaled
from scara_ident_ros.nn.network import FeedForwardNet, forward_scaled
from scara_ident_ros.nn.training import STOP_MU_MAX, FitHistory, StopTraining

__all__ = ['LevenbergMarquardt', 'NormalBlocks', 'normal_blocks', 'normal_equations']

FloatArray = npt.NDArray[np.float64]


class NormalBlocks:
    """The blocks of the normal equations at one set of weights (module docstring).

    Attributes
    ----------
    ztz : ndarray of shape (n_h, n_h)
        ZᵀZ, n_h = (n_inputs + 1)·n_hidden.
    zht : ndarray of shape (n_h, n_hidden + 1)
        Zᵀh̃.
    hth : ndarray of shape (n_hidden + 1, n_hidden + 1)
        h̃ᵀh̃.
    W : ndarray of shape (n_outputs, n_hidden)
        Output weights without the bias column.
    jtr : ndarray of shape (n_params,)
        Jᵀr, r = ŷ − y.
    sse : float
        Σ r².
    """

    def __init__(self, ztz: FloatArray, zht: FloatArray, hth: FloatArray, W: FloatArray,
                 jtr: FloatArray, sse: float) -> None:
        self.ztz, self.zht, self.hth, self.W, self.jtr, self.sse = ztz, zht, hth, W, jtr, sse
        self._n_out, self._n_hid = W.shape
        self._n_in1 = ztz.shape[0] // self._n_hid  # n_inputs + 1
        self._weight = np.tile(W.T @ W, (self._n_in1, self._n_in1))  # 1 ⊗ WᵀW

    @property
    def n_params(self) -> int:
        """Number of weights."""
        return int(self.jtr.shape[0])

    def matrix(self, out: FloatArray | None = None) -> FloatArray:
        """JᵀJ (n_params, n_params), the plain normal equations' matrix."""
        n_h, n_hid, n_out = self.ztz.shape[0], self._n_hid, self._n_out
        jtj = out if out is not None else np.empty((self.n_params, self.n_params))
        np.multiply(self.ztz, self._weight, out=jtj[:n_h, :n_h])
        cross = (self.zht.reshape(self._n_in1, n_hid, 1, n_hid + 1)
                 * self.W.T[None, :, :, None]).reshape(n_h, n_out * (n_hid + 1))
        jtj[:n_h, n_h:] = cross
        jtj[n_h:, :n_h] = cross.T
        jtj[n_h:, n_h:] = 0.0
        for j in range(n_out):
            block = slice(n_h + j * (n_hid + 1), n_h + (j + 1) * (n_hid + 1))
            jtj[block, block] = self.hth
        return jtj

    def solve(self, mu: float) -> FloatArray:
        """δ of (JᵀJ + μI)·δ = Jᵀr by the Schur complement on the hidden weights.

        Raises
        ------
        numpy.linalg.LinAlgError
            If JᵀJ + μI is not positive definite to working precision.
        """
        n_h, n_hid, n_out = self.ztz.shape[0], self._n_hid, self._n_out
        k = self.hth + mu * np.eye(n_hid + 1)
        k_lower = np.linalg.cholesky(k)
        # A = L_K⁻¹ (Zᵀh̃)ᵀ, so (Zᵀh̃) K⁻¹ (Zᵀh̃)ᵀ = AᵀA
        a = solve_triangular(k_lower, self.zht.T, lower=True, check_finite=False)
        schur = self.ztz - a.T @ a
        schur *= self._weight
        schur.reshape(-1)[::n_h + 1] += mu
        lower = np.linalg.cholesky(schur)
        g_h, g_o = self.jtr[:n_h], self.jtr[n_h:].reshape(n_out, n_hid + 1)
        # hidden right-hand side: g_h − Σ_j C_j K⁻¹ g_o,j, C_j = diag(1 ⊗ W_j)·Zᵀh̃
        p = self.zht @ cho_solve((k_lower, True), g_o.T, check_finite=False)  # (n_h, n_out)
        rhs = g_h - np.einsum('ihj,jh->ih', p.reshape(self._n_in1, n_hid, n_out),
                              self.W).reshape(n_h)
        delta_h = cho_solve((lower, True), rhs, check_finite=False)
        # output weights: K δ_o,j = g_o,j − C_jᵀ δ_h
        scaled = delta_h.reshape(self._n_in1, n_hid, 1) * self.W.T[None, :, :]
        c_t_delta = self.zht.T @ scaled.reshape(n_h, n_out)  # (n_hid + 1, n_out)
        delta_o = cho_solve((k_lower, True), g_o.T - c_t_delta, check_finite=False)
        return np.concatenate([delta_h, delta_o.T.reshape(-1)])


def normal_blocks(net: FeedForwardNet, xs: FloatArray, ys: FloatArray, *,
                  chunk_size: int = 1024, jtr: FloatArray | None = None,
                  single: bool = False) -> NormalBlocks:
    """Return the blocks of JᵀJ, Jᵀr and the sum of squared errors at the network's weights.

    Parameters as :func:`normal_equations`; ``jtr`` a buffer (n_params,) for Jᵀr.
    """
    n_in, n_hid = net.n_inputs, net.n_hidden
    n_h = (n_in + 1) * n_hid  # hidden-layer parameters come first in θ
    jtr = jtr if jtr is not None else np.empty(net.n_params)
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
        layers = forward_scaled(net, x_chunk, derivative=True)
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
    return NormalBlocks(ztz.astype(np.float64, copy=False), zht.astype(np.float64, copy=False),
                        hth, W.copy(), jtr, sse)


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
    jtj, jtr = out if out is not None else (np.empty((net.n_params, net.n_params)),
                                            np.empty(net.n_params))
    blocks = normal_blocks(net, xs, ys, chunk_size=chunk_size, jtr=jtr, single=single)
    blocks.matrix(out=jtj)
    return jtj, jtr, blocks.sse


class LevenbergMarquardt:
    """A `training.TrainingStep` doing Levenberg–Marquardt (module docstring).

    Parameters
    ----------
    net, xs, ys
        The network to train and its scaled samples, as `training.TrainingStep` says.
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
    structured : bool, default True
        Solve the damped system on its blocks (:meth:`NormalBlocks.solve`); False: one
        Cholesky of the whole JᵀJ + μI (the same step to rounding, more time).
    weight_decay : float, default 0.0
        λ ≥ 0 of the L2 penalty λ‖θ‖² added to the sum of squared errors (module
        docstring); 0 trains exactly as without it. The MSE `step` returns stays the data's
        alone.
    """

    def __init__(self, net: FeedForwardNet, xs: FloatArray, ys: FloatArray, *,
                 mu: float = 1e-3, mu_decrease: float = 0.1, mu_increase: float = 10.0,
                 mu_max: float = 1e10, chunk_size: int = 1024, single: bool = False,
                 structured: bool = True, weight_decay: float = 0.0) -> None:
        if not (mu > 0.0 and 0.0 < mu_decrease < 1.0 < mu_increase and mu_max >= mu):
            raise ValueError('need mu > 0, 0 < mu_decrease < 1 < mu_increase, mu_max >= mu')
        if not (np.isfinite(weight_decay) and weight_decay >= 0.0):
            raise ValueError(f'weight_decay must be finite and >= 0, got {weight_decay}')
        self._net, self._xs, self._ys = net, xs, ys
        self.mu = mu
        self._mu_decrease, self._mu_increase, self._mu_max = mu_decrease, mu_increase, mu_max
        self._chunk_size = chunk_size
        self._single = single
        self._structured = structured
        self._decay = float(weight_decay)
        n_params = net.n_params
        self._jtr = np.empty(n_params)
        self._blocks: NormalBlocks | None = None
        self._jtj = np.empty((0, 0) if structured else (n_params, n_params))
        self._trial = np.empty(n_params)
        self._sse = np.inf
        self._loss = np.inf  # Σ r² + λ‖θ‖², what a step must lower
        self._stale = True  # normal equations not assembled at the current weights
        self._history: FitHistory | None = None

    def start(self, history: FitHistory) -> float:
        """Keep ``history`` for the damping log; return the current training MSE."""
        self._history = history
        return self.set_data(self._xs, self._ys)

    def set_data(self, xs: FloatArray, ys: FloatArray) -> float:
        """Train on other samples ``xs, ys`` (as the constructor's) from now on, keeping mu;
        return their current MSE.

        For learning beside a stream, where the samples (a reservoir) change between steps.
        """
        self._xs, self._ys = xs, ys
        self._sse = mse_scaled(self._net, xs, ys) * ys.size
        self._loss = self._sse + self._penalty(self._net.theta)
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
            self._blocks = normal_blocks(net, self._xs, self._ys, chunk_size=self._chunk_size,
                                         jtr=self._jtr, single=self._single)
            if self._decay:
                self._jtr += self._decay * net.theta  # the penalty's gradient (halved)
            if not self._structured:
                self._blocks.matrix(out=self._jtj)
            self._stale = False
        while self.mu <= self._mu_max:
            try:
                delta = self._solve(self.mu)
            except np.linalg.LinAlgError:  # not positive definite at this damping
                self.mu *= self._mu_increase
                continue
            np.subtract(net.theta, delta, out=self._trial)
            sse = mse_scaled(net, self._xs, self._ys, self._trial) * self._ys.size
            loss = sse + self._penalty(self._trial)
            if loss < self._loss:
                np.copyto(net.theta, self._trial)
                self._sse, self._loss = sse, loss
                self._stale = True
                if self._history is not None:
                    self._history.mu.append(self.mu)
                self.mu *= self._mu_decrease
                return sse / self._ys.size
            self.mu *= self._mu_increase
        raise StopTraining(STOP_MU_MAX)

    def _penalty(self, theta: FloatArray) -> float:
        """λ‖θ‖² (0.0 without weight decay)."""
        return self._decay * float(np.vdot(theta, theta)) if self._decay else 0.0

    def _solve(self, mu: float) -> FloatArray:
        """δ of (JᵀJ + (μ + λ)I)·δ = Jᵀr + λθ at the assembled weights."""
        assert self._blocks is not None
        if self._decay:
            mu = mu + self._decay
        if self._structured:
            return self._blocks.solve(mu)
        work = self._jtj.copy()
        work.reshape(-1)[::work.shape[0] + 1] += mu
        lower = np.linalg.cholesky(work)
        return np.asarray(cho_solve((lower, True), self._jtr, check_finite=False))
