"""Exact Gaussian-process regression of joint efforts, learnt offline in one Cholesky or
online by appending one row to the Cholesky factor per sample, thinned evenly once full.

Inputs are standardised with the training data (u = (x − x_mean) / x_scale), efforts too
(t = (y − y_mean) / y_scale). One squared-exponential kernel with one isotropic length ℓ
and unit signal variance is shared by the joints, so one factor serves them all::

    K = k(U, U) + σ² I = L Lᵀ,   k(u, v) = exp(−|u − v|² / (2ℓ²))
    β = L⁻¹ T  (n, joints),   α = L⁻ᵀ β,   mean(u*) = k(u*, U) α

ℓ and σ² are chosen from a grid (:data:`LENGTHS` × :data:`NOISES`) by the SMSE of the
exact GP on validation blocks of the training rows (:func:`choose_kernel`: one block of
``val_block`` consecutive rows in every ``val_every``), never on held-out data. On the
Barrett WAM the marginal likelihood picks a far smoother kernel (SMSE 0.044 where
validation reaches 1e-4, benchmarks/realdata.md): the test rows lie between training rows
in time, and the GP interpolates between neighbours.

Online (:meth:`ExactGP.partial_fit`), each sample is predicted, then appended::

    l = L⁻¹ k(U, u),   d = √(1 + σ² − lᵀl),   L ← [[L, 0], [lᵀ, d]],
    β ← [β; (t − lᵀβ) / d],   prediction before learning = lᵀβ

(one triangular solve, O(n²), done blockwise on the preallocated factor so that no n × n
copy is made). The first ``warmup`` rows are only buffered (predicted by the mean of the
efforts before them); then the standardisation and kernel are set from them and they are
factored at once. Samples the model already predicts within ``skip_within`` noise standard
deviations on every joint, or whose latent predictive variance (d² − σ², free from the
solve) is below ``min_variance``, are predicted and skipped (0, the defaults: learn every
sample the budget rule lets in).

Once ``budget`` points are held, ``budget_rule='thin'`` (the default) keeps them spread
evenly over the whole stream: only samples at a multiple of the stride s (stream position,
s = 1 at first) are learnt, and each needs room: the oldest points at an odd multiple of s
are evicted, ``budget // 8`` at a time, and the points after the first evicted one are
factored again (the rows before it stand: L₃₃ = chol(K₃₃ − L₃₁ L₃₁ᵀ), O(n³) at worst, a few
times per doubling of the stream). When no point at an odd multiple is left, s doubles. So
the model always holds an older part of the stream at stride 2s and the recent part at s,
between 7/8 of the budget and all of it, e.g. after 12,000 samples with a budget of 4,000:
rows 0-7,999 at stride 4 and 8,000-11,998 at stride 2. ``budget_rule='stop'`` predicts
only once full. With ``skip_within=0``, ``min_variance=0`` and a budget above the stream,
one pass of ``partial_fit`` gives the factor of ``fit`` on the same rows; after evictions,
the factor is the batch Cholesky of the points kept (test/learners).

Measured on the WAM's published split (benchmarks/realdata.md; load 7-16 on 2 cores):
``fit`` on the 12,000 rows scores SMSE 9.8e-4 (8.8e-5 with ``val_block=1``; 42-61 s);
online, one pass in order, frozen, budget 4,000: 0.0049 with the defaults ('thin': 4,000
points over the whole stream; 6 ms median per sample, 31 ms p99, 3.6 s at worst while
refactoring, at load 11; 128 MB), 0.026 with 'stop' and ``min_variance`` 0.1 (3,730 points
from the start), 0.146 with 'stop' learning every sample until full; 0.0011 with the
budget at every row (1.15 GB; 24-98 ms per sample at 12,000 points). Rules measured
first as ``fit`` on the rows each would keep (kernel length 3.5, noise 0.01): every 3rd row
(4,000, evenly) 0.0044; 'thin' 0.0049; stride doubling
all at once (every 4th row, 3,000) 0.0062; reservoir sampling (4,000 at random, seeds 0
and 1) 0.021 and 0.017: the gaps it leaves cost more than the points it adds.
"""
from __future__ import annotations

import operator
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.linalg import LinAlgError, solve_triangular
from scipy.linalg.lapack import dpotrf

from scara_ident_ros.estimator import SavedEstimator, check_samples, register_kind
from scara_ident_ros.nn.errors import ModelFormatError

__all__ = ['BUDGET', 'BUDGET_RULE', 'BUDGET_RULES', 'KIND', 'LENGTHS', 'MIN_VARIANCE',
           'NOISES', 'SELECT_SAMPLES', 'VAL_BLOCK', 'WARMUP', 'ExactGP', 'choose_kernel',
           'rbf']

KIND = 'gp'  #: the model file's kind
#: The grid: isotropic length on standardised inputs, noise variance of the standardised
#: effort (signal variance 1); the benchmark's grid.
LENGTHS = (1.0, 2.0, 3.5, 5.0, 8.0)
NOISES = (1e-4, 1e-2)
BUDGET = 4000  #: default online budget: points in the factor
#: What ``partial_fit`` does once the budget is full: 'thin' keeps the points spread over
#: the whole stream (module docstring), 'stop' only predicts (learns nothing more).
BUDGET_RULES = ('thin', 'stop')
BUDGET_RULE = 'thin'  #: the default rule
WARMUP = 1000  #: default rows buffered online before the kernel is chosen
#: Default online novelty threshold: 0, learn every sample the budget rule lets in. With
#: 'stop' on the WAM (budget 4000) 0.1 scored SMSE 0.030 against 0.146 learning every sample
#: until full; with 'thin' 0.1 keeps the budget from filling (3,730 points from the start
#: of the stream, 0.026) where 0 spreads 4,000 over it (0.0049; realdata.md).
MIN_VARIANCE = 0.0
SELECT_SAMPLES = 3000  #: default rows (the first ones) the offline kernel is chosen on
#: Default validation blocks: 50 consecutive rows, one block in 10. Single rows (1) suit
#: the WAM, whose test rows lie between training rows (SMSE 9e-5 against 9.8e-4 with 50),
#: but choose almost no noise on recordings held out in blocks (TX40 9.1 against 0.114,
#: TIAGo 1.55 against 0.62): 50 meets the WAM's target and holds on both.
VAL_BLOCK = 50
_BLOCK = 512  # rows per block of the blockwise triangular solves
_EVICT_PARTS = 8  # 'thin' evicts budget // 8 points at a time (one factorisation each)
_CHUNK = 1024  # rows per block when filling a kernel matrix


def rbf(a: np.ndarray, b: np.ndarray, length: float) -> np.ndarray:
    """Squared-exponential kernel (len(a), len(b)) of standardised inputs, unit signal."""
    d2 = (a ** 2).sum(1)[:, None] + (b ** 2).sum(1)[None, :] - 2.0 * (a @ b.T)
    return np.asarray(np.exp(-0.5 * np.maximum(d2, 0.0) / length ** 2))


def _validation_mask(n: int, val_block: int, val_every: int) -> np.ndarray:
    """Rows in the last block of every ``val_every`` blocks of ``val_block`` rows."""
    return (np.arange(n) // val_block) % val_every == val_every - 1


def choose_kernel(u: np.ndarray, t: np.ndarray, *, lengths: tuple[float, ...] = LENGTHS,
                  noises: tuple[float, ...] = NOISES, val_block: int = 1,
                  val_every: int = 10) -> tuple[float, float, dict[tuple[float, float],
                                                                   float]]:
    """Length and noise of the grid whose exact GP, trained on the rows outside the
    validation blocks, has the lowest SMSE on them.

    Parameters
    ----------
    u : ndarray of shape (N, d)
        Standardised inputs, in time order.
    t : ndarray of shape (N, k)
        Standardised efforts.
    val_block, val_every : int
        Validation rows: one block of ``val_block`` consecutive rows in every ``val_every``.

    Returns
    -------
    length, noise : float
    scores : dict of (length, noise) to float
        Validation SMSE of each grid point.
    """
    val = _validation_mask(len(u), val_block, val_every)
    if val.all() or not val.any():
        raise ValueError(f'{len(u)} rows leave no training or no validation rows')
    fit, check = u[~val], u[val]
    t_fit, t_val = t[~val], t[val]
    deviation = float(((t_val - t_val.mean(axis=0)) ** 2).sum()) or 1.0
    scores: dict[tuple[float, float], float] = {}
    for length in lengths:
        gram = rbf(fit, fit, length)
        cross = rbf(check, fit, length)
        for noise in noises:
            a = gram.copy()
            a[np.diag_indices_from(a)] += noise
            factor, info = dpotrf(a, lower=1, clean=0, overwrite_a=1)
            if info:
                continue
            beta = solve_triangular(factor, t_fit, lower=True, check_finite=False)
            alpha = solve_triangular(factor, beta, lower=True, trans='T', check_finite=False)
            scores[length, noise] = float(((t_val - cross @ alpha) ** 2).sum()) / deviation
    if not scores:
        raise LinAlgError('no kernel of the grid is positive definite on these rows')
    length, noise = min(scores, key=scores.__getitem__)
    return length, noise, scores


class ExactGP(SavedEstimator):
    """Exact GP regression of joint efforts: one kernel, one Cholesky, weights per joint.

    Parameters
    ----------
    length, noise : float, optional
        Fix the kernel (length on standardised inputs, noise variance of the standardised
        effort); by default both are chosen by :func:`choose_kernel`.
    budget : int, default :data:`BUDGET`
        Online: most points in the factor (it is allocated at this size).
    budget_rule : {'thin', 'stop'}, default 'thin'
        Online, once ``budget`` points are held: 'thin' learns every ``stride_``-th sample
        and evicts for each the oldest point at an odd multiple of the stride (the stride
        doubles when none is left), so that the points stay spread evenly over the whole
        stream; 'stop' only predicts.
    warmup : int, default 1000
        Online: rows buffered before the standardisation and kernel are set from them.
    skip_within : float, default 0.0
        Online: skip a sample predicted within this many noise standard deviations on every
        joint (0: learn every sample until the budget is full).
    min_variance : float, default 0.0
        Online: skip a sample whose latent predictive variance (standardised, at most 1)
        is below this: its neighbours in the model cover it (0: learn every sample).
    select_samples : int, default 3000
        Offline: the kernel is chosen on the first this many rows of ``fit``.
    val_block, val_every : int, default 50 and 10
        Validation rows of :func:`choose_kernel`.

    Attributes
    ----------
    n_inputs_, n_outputs_ : int
        d = 3n and n.
    x_mean_, x_scale_ : ndarray of shape (d,)
    y_mean_, y_scale_ : ndarray of shape (n,)
        Standardisation (inputs' units; N·m, N).
    length_, noise_ : float
        The kernel.
    selection_ : dict of (length, noise) to float
        Validation SMSE of the grid (empty if the kernel was given).
    n_points_ : int
        Points in the model.
    n_seen_ : int
        Samples given to ``partial_fit`` (skipped ones included).
    stride_ : int
        Online, 'thin': samples at a multiple of it (stream position) are learnt.
    n_evicted_ : int
        Online, 'thin': points evicted to keep the budget.
    metadata : dict of str to ndarray
        Saved with the model.
    """

    kind = KIND

    def __init__(self, *, length: float | None = None, noise: float | None = None,
                 budget: int = BUDGET, warmup: int = WARMUP, skip_within: float = 0.0,
                 min_variance: float = MIN_VARIANCE,
                 select_samples: int = SELECT_SAMPLES, val_block: int = VAL_BLOCK,
                 val_every: int = 10, budget_rule: str = BUDGET_RULE) -> None:
        if (length is None) != (noise is None):
            raise ValueError('give both length and noise, or neither')
        if length is not None and not (length > 0.0 and noise is not None and noise > 0.0):
            raise ValueError(f'length and noise must be positive, got {length}, {noise}')
        budget, warmup = operator.index(budget), operator.index(warmup)
        if not 2 <= warmup <= budget:
            raise ValueError(f'need 2 <= warmup <= budget, got {warmup} and {budget}')
        if skip_within < 0.0:
            raise ValueError(f'skip_within must be >= 0, got {skip_within}')
        if operator.index(val_block) < 1 or operator.index(val_every) < 2:
            raise ValueError('need val_block >= 1 and val_every >= 2')
        if budget_rule not in BUDGET_RULES:
            raise ValueError(f'budget_rule must be one of {", ".join(BUDGET_RULES)}, '
                             f'got {budget_rule!r}')
        self.length = None if length is None else float(length)
        self.noise = None if noise is None else float(noise)
        self.budget = budget
        self.warmup = warmup
        self.skip_within = float(skip_within)
        self.min_variance = float(min_variance)
        self.select_samples = operator.index(select_samples)
        self.val_block = int(val_block)
        self.val_every = int(val_every)
        self.budget_rule = str(budget_rule)
        self.metadata: dict[str, np.ndarray] = {}
        self.selection_: dict[tuple[float, float], float] = {}
        self.n_points_ = 0
        self.n_seen_ = 0
        self.stride_ = 1
        self.n_evicted_ = 0
        self._stream = 0  # stream position of the next partial_fit sample
        self._positions = np.zeros(0, np.int64)  # stream position of each point
        self._ready = False
        self._buffer: list[tuple[np.ndarray, np.ndarray]] = []  # warm-up rows
        self._factor: np.ndarray | None = None   # L (capacity, capacity), lower rows
        self._alpha: np.ndarray | None = None    # α, None when stale

    # ----------------------------------------------------------------- estimator contract
    def get_params(self) -> dict[str, Any]:
        """The constructor's hyperparameters, as data."""
        return {'length': self.length, 'noise': self.noise, 'budget': self.budget,
                'warmup': self.warmup, 'skip_within': self.skip_within,
                'min_variance': self.min_variance,
                'select_samples': self.select_samples, 'val_block': self.val_block,
                'val_every': self.val_every, 'budget_rule': self.budget_rule}

    def fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> ExactGP:
        """Learn every sample of X (N, 3n), Y (N, n) in one Cholesky (not limited by the
        budget). The standardisation and kernel come from these samples unless
        :meth:`set_kernel` gave them; whatever was learnt before is forgotten."""
        x, y = self._check(X, Y, first=True)
        if not self._ready:
            self.set_kernel(x[:self.select_samples], y[:self.select_samples])
        u, t = self._standardise(x, y)
        n = len(u)
        capacity = max(n, self.budget)
        a = np.empty((capacity, capacity)) if capacity == n else np.empty((n, n))
        for start in range(0, n, _CHUNK):  # lower rows suffice; fill all (BLAS is faster)
            a[start:start + _CHUNK, :n] = rbf(u[start:start + _CHUNK], u, self.length_)
        a[np.diag_indices(n)] += self.noise_
        # a is C-ordered and symmetric: its transpose is the F-ordered matrix LAPACK wants,
        # whose upper factor U = Lᵀ lands in a's lower triangle.
        factor, info = dpotrf(a.T, lower=0, clean=0, overwrite_a=1)
        if info:
            raise LinAlgError(f'the kernel matrix is not positive definite (info {info})')
        if capacity == n:
            lower = factor.T
        else:
            lower = np.empty((capacity, capacity))
            lower[:n, :n] = factor.T
        self._factor = lower
        self._points, self._targets = self._storage(capacity)
        self._points[:n], self._targets[:n] = u, t
        self._positions = np.empty(capacity, np.int64)
        self._positions[:n] = np.arange(n)
        self._stream, self.stride_, self.n_evicted_ = n, 1, 0
        self.n_points_ = n
        self._beta = self._storage(capacity)[1]
        self._beta[:n] = self._forward(t)
        self._alpha = None
        self._buffer = []
        return self

    def partial_fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> np.ndarray:
        """Predict each sample, then learn it (module docstring: warm-up, budget, skips).

        Returns
        -------
        ndarray of shape (N, n)
            Each sample's prediction made before it was learnt (N·m, N).
        """
        x, y = self._check(X, Y, first=not self._ready and not self._buffer)
        out = np.empty_like(y)
        for i in range(len(x)):
            self.n_seen_ += 1
            if not self._ready:
                out[i] = (np.mean([row[1] for row in self._buffer], axis=0)
                          if self._buffer else 0.0)
                self._buffer.append((x[i], y[i]))
                if len(self._buffer) >= self.warmup:
                    rows_x = np.array([row[0] for row in self._buffer])
                    rows_y = np.array([row[1] for row in self._buffer])
                    self._buffer = []
                    self.set_kernel(rows_x, rows_y)
                    self.fit(rows_x, rows_y)
                continue
            if self._factor is None:  # kernel set, nothing learnt yet
                self._allocate()
            u, t = self._standardise(x[i:i + 1], y[i:i + 1])
            out[i] = self._append(u[0], t[0], self._stream) * self.y_scale_ + self.y_mean_
            self._stream += 1
        return out

    def predict(self, X: npt.ArrayLike) -> np.ndarray:
        """Efforts (N, n) for inputs X (N, 3n) (N·m, N)."""
        self._need_ready()
        x = np.asarray(X, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_inputs_:
            raise ValueError(f'X must have shape (N, {self.n_inputs_}), got {x.shape}')
        n = self.n_points_
        if n == 0:
            return np.tile(self.y_mean_, (len(x), 1))
        alpha = self._weights()
        u = (x - self.x_mean_) / self.x_scale_
        out = np.empty((len(x), self.n_outputs_))
        for start in range(0, len(x), _CHUNK):
            out[start:start + _CHUNK] = rbf(u[start:start + _CHUNK], self._points[:n],
                                            self.length_) @ alpha
        return out * self.y_scale_ + self.y_mean_

    # ------------------------------------------------------------------ state and kernel
    def set_kernel(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> ExactGP:
        """Set the standardisation from X (N, 3n), Y (N, n) and the kernel (the given one,
        or :func:`choose_kernel` on these rows); forgets what was learnt."""
        x, y = self._check(X, Y, first=True)
        self.n_inputs_, self.n_outputs_ = x.shape[1], y.shape[1]
        self.x_mean_, self.x_scale_ = x.mean(axis=0), _scale(x.std(axis=0))
        self.y_mean_, self.y_scale_ = y.mean(axis=0), _scale(y.std(axis=0))
        if self.length is not None and self.noise is not None:
            self.length_, self.noise_ = self.length, self.noise
            self.selection_ = {}
        else:
            u, t = self._standardise(x, y)
            self.length_, self.noise_, self.selection_ = choose_kernel(
                u, t, val_block=self.val_block, val_every=self.val_every)
        self._ready = True
        self._factor = None
        self._alpha = None
        self.n_points_ = 0
        self._stream, self.stride_, self.n_evicted_ = 0, 1, 0
        self._positions = np.zeros(0, np.int64)
        return self

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The entries that :meth:`from_arrays` rebuilds the model from."""
        self._need_ready()
        n = self.n_points_
        empty = np.zeros((0, self.n_outputs_))
        params = np.array([self.budget, self.warmup, self.select_samples, self.val_block,
                           self.val_every, self.n_seen_], np.int64)
        given = np.array([np.nan if self.length is None else self.length,
                          np.nan if self.noise is None else self.noise])
        return {'params': params, 'given': given, 'skip_within': np.array(self.skip_within),
                'min_variance': np.array(self.min_variance),
                'budget_rule': np.array(self.budget_rule),
                'stream': np.array([self._stream, self.stride_, self.n_evicted_], np.int64),
                'positions': self._positions[:n] if n else np.zeros(0, np.int64),
                'kernel': np.array([self.length_, self.noise_]),
                'x_mean': self.x_mean_, 'x_scale': self.x_scale_, 'y_mean': self.y_mean_,
                'y_scale': self.y_scale_,
                'points': self._points[:n] if n else np.zeros((0, self.n_inputs_)),
                'targets': self._targets[:n] if n else empty,
                'alpha': self._weights() if n else empty}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], *, source: str) -> ExactGP:
        """Rebuild a model from :meth:`to_arrays`' entries (``ModelFormatError`` if an
        entry is missing or has the wrong type or shape)."""
        try:
            budget, warmup, select, val_block, val_every, seen = (
                int(v) for v in arrays['params'])
            length, noise = (float(v) for v in arrays['given'])
            given = not np.isnan(length)
            model = cls(length=length if given else None, noise=noise if given else None,
                        budget=budget, warmup=warmup,
                        skip_within=float(arrays['skip_within']),
                        min_variance=float(arrays['min_variance']), select_samples=select,
                        val_block=val_block, val_every=val_every,
                        # files written before the rule existed stopped when full
                        budget_rule=str(arrays['budget_rule']) if 'budget_rule' in arrays
                        else 'stop')
            values = {name: np.asarray(arrays[name], dtype=np.float64) for name in
                      ('kernel', 'x_mean', 'x_scale', 'y_mean', 'y_scale', 'points',
                       'targets', 'alpha')}
            for name, value in values.items():
                if not np.all(np.isfinite(value)):
                    raise ValueError(f'{name} must be finite')
            points, targets = values['points'], values['targets']
            d, k, n = values['x_mean'].shape[0], values['y_mean'].shape[0], points.shape[0]
            expected = {'kernel': (2,), 'x_scale': (d,), 'y_scale': (k,), 'points': (n, d),
                        'targets': (n, k), 'alpha': (n, k)}
            for name, shape in expected.items():
                if values[name].shape != shape:
                    raise ValueError(f'{name} has shape {values[name].shape}, not {shape}')
            model.n_inputs_, model.n_outputs_ = d, k
            model.x_mean_, model.x_scale_ = values['x_mean'], values['x_scale']
            model.y_mean_, model.y_scale_ = values['y_mean'], values['y_scale']
            model.length_, model.noise_ = (float(v) for v in values['kernel'])
            model._ready = True
            model._points, model._targets = points, targets
            model._alpha = values['alpha']
            model.n_points_, model.n_seen_ = n, seen
            positions = np.asarray(arrays.get('positions', np.arange(n)), dtype=np.int64)
            stream, stride, evicted = (int(v) for v in arrays.get(
                'stream', np.array([n, 1, 0])))
            if positions.shape != (n,) or np.any(np.diff(positions) <= 0) or (
                    n and not 0 <= positions[0] <= positions[-1] < stream) or stride < 1:
                raise ValueError('positions must increase within the stream, stride >= 1')
            model._positions, model._stream = positions, stream
            model.stride_, model.n_evicted_ = stride, evicted
        except (KeyError, ValueError, TypeError) as exc:
            raise ModelFormatError(f'{source}: corrupt gp model: '
                                   f'{" ".join(str(exc).split())}') from None
        return model

    # ------------------------------------------------------------------------- internals
    def _need_ready(self) -> None:
        if not self._ready:
            raise RuntimeError('the model has learnt nothing yet: call fit or partial_fit '
                               '(online, the first warmup rows are only buffered)')

    def _check(self, X: npt.ArrayLike, Y: npt.ArrayLike, *, first: bool
               ) -> tuple[np.ndarray, np.ndarray]:
        shape = None if first else (
            (self.n_inputs_, self.n_outputs_) if self._ready else
            (len(self._buffer[0][0]), len(self._buffer[0][1])))
        return check_samples(X, Y, shape)

    def _standardise(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (x - self.x_mean_) / self.x_scale_, (y - self.y_mean_) / self.y_scale_

    def _storage(self, capacity: int) -> tuple[np.ndarray, np.ndarray]:
        return np.empty((capacity, self.n_inputs_)), np.empty((capacity, self.n_outputs_))

    def _allocate(self) -> None:
        """An empty factor of ``budget`` rows (first sample after set_kernel or load)."""
        n = self.n_points_
        points = self._points[:n] if n else np.zeros((0, self.n_inputs_))
        targets = self._targets[:n] if n else np.zeros((0, self.n_outputs_))
        positions = self._positions[:n].copy()
        self._points, self._targets = self._storage(max(self.budget, n))
        self._points[:n], self._targets[:n] = points, targets
        self._positions = np.empty(max(self.budget, n), np.int64)
        self._positions[:n] = positions
        self._beta = self._storage(max(self.budget, n))[1]
        self._factor = np.empty((max(self.budget, n),) * 2)
        if n:  # after load: refactor the points
            a = rbf(points, points, self.length_)
            a[np.diag_indices(n)] += self.noise_
            factor, info = dpotrf(a, lower=1, clean=0, overwrite_a=1)
            if info:
                raise LinAlgError(f'the kernel matrix is not positive definite (info {info})')
            self._factor[:n, :n] = factor
            self._beta[:n] = self._forward(targets)

    def _append(self, u: np.ndarray, t: np.ndarray, position: int) -> np.ndarray:
        """Predict (standardised) and learn one sample at stream ``position``; returns the
        prediction made before learning."""
        n = self.n_points_
        assert self._factor is not None
        if n == 0:
            prediction = np.zeros_like(t)
            l_row = np.zeros(0)
        else:
            k = rbf(u[None, :], self._points[:n], self.length_)[0]
            full = n >= len(self._factor) or n >= self.budget
            if (full and self.budget_rule == 'stop') or position % self.stride_:
                return np.asarray(k @ self._weights())  # predict only, O(n)
            l_row = self._forward(k)
            prediction = l_row @ self._beta[:n]
        if (n and self.skip_within > 0.0 and np.all(
                np.abs(t - prediction) <= self.skip_within * np.sqrt(self.noise_))):
            return prediction
        diagonal = 1.0 + self.noise_ - float(l_row @ l_row)  # predictive variance
        if n and diagonal - self.noise_ < self.min_variance:  # covered by its neighbours
            return prediction
        if n and full:  # 'thin': make room, then the row of the smaller factor
            self._evict()
            n = self.n_points_
            l_row = self._forward(rbf(u[None, :], self._points[:n], self.length_)[0])
            diagonal = 1.0 + self.noise_ - float(l_row @ l_row)
        d = np.sqrt(max(diagonal, 1e-12 * self.noise_))
        self._factor[n, :n] = l_row
        self._factor[n, n] = d
        self._points[n], self._targets[n] = u, t
        self._positions[n] = position
        self._beta[n] = (t - l_row @ self._beta[:n]) / d
        self.n_points_ = n + 1
        self._alpha = None
        if self.n_evicted_:  # thinning: no point at an odd multiple left: double the stride
            positions = self._positions[:n + 1]
            while (self.stride_ <= positions[-1]
                   and not np.any((positions // self.stride_) % 2)):
                self.stride_ *= 2
        return prediction

    def _evict(self) -> None:
        """Evict the ``budget // 8`` oldest points at an odd multiple of the stride (fewer
        if fewer are left; the stride doubles when none is), then factor the points after
        the first evicted one again: the rows before it stand, and with L₃₁ the kept rows'
        columns before it, L₃₃ = chol(K₃₃ − L₃₁ L₃₁ᵀ), β₃ = L₃₃⁻¹ (T₃ − L₃₁ β₁)."""
        assert self._factor is not None
        lower, n = self._factor, self.n_points_
        positions = self._positions[:n]
        odd = np.zeros(0, np.int64)
        while not len(odd) and self.stride_ <= positions[-1]:
            odd = np.flatnonzero((positions // self.stride_) % 2)
            if not len(odd):
                self.stride_ *= 2
        if not len(odd):  # not reached for distinct positions
            odd = np.array([n - 1])
        evicted = odd[:max(1, self.budget // _EVICT_PARTS)]
        j = int(evicted[0])
        tail = np.setdiff1d(np.arange(j, n), evicted)
        m = len(tail)
        for rows in (self._points, self._targets, self._positions):
            rows[j:j + m] = rows[tail]
        if m:
            outer = lower[tail, :j]  # a copy: L₃₁ of the kept rows
            gram = rbf(self._points[j:j + m], self._points[j:j + m], self.length_)
            gram[np.diag_indices(m)] += self.noise_
            if j:
                gram -= outer @ outer.T
            factor, info = dpotrf(gram.T, lower=0, clean=0, overwrite_a=1)
            if info:
                raise LinAlgError(f'the kernel matrix is not positive definite (info {info})')
            lower[j:j + m, :j] = outer
            lower[j:j + m, j:j + m] = factor.T
            rhs = self._targets[j:j + m] - outer @ self._beta[:j]
            self._beta[j:j + m] = self._forward(rhs, start=j)
        self.n_points_ = j + m
        self.n_evicted_ += len(evicted)
        self._alpha = None

    def _forward(self, b: np.ndarray, start: int = 0) -> np.ndarray:
        """L⁻¹ b for b (n,) or (n, k), blockwise on views of the factor (no n × n copy);
        with ``start``, the solve on the factor's trailing block from row ``start``."""
        assert self._factor is not None
        n = len(b)
        lower = self._factor[start:start + n, start:start + n]
        out = np.array(b, dtype=np.float64)
        for r0 in range(0, n, _BLOCK):
            r1 = min(r0 + _BLOCK, n)
            if r0:
                out[r0:r1] -= lower[r0:r1, :r0] @ out[:r0]
            out[r0:r1] = solve_triangular(lower[r0:r1, r0:r1], out[r0:r1], lower=True,
                                          check_finite=False)
        return out

    def _backward(self, b: np.ndarray) -> np.ndarray:
        """L⁻ᵀ b for b (n, k), blockwise."""
        assert self._factor is not None
        lower, n = self._factor, len(b)
        out = np.array(b, dtype=np.float64)
        for r0 in reversed(range(0, n, _BLOCK)):
            r1 = min(r0 + _BLOCK, n)
            if r1 < n:
                out[r0:r1] -= lower[r1:n, r0:r1].T @ out[r1:n]
            out[r0:r1] = solve_triangular(lower[r0:r1, r0:r1], out[r0:r1], lower=True,
                                          trans='T', check_finite=False)
        return out

    def _weights(self) -> np.ndarray:
        """α (n, joints), recomputed after appends."""
        if self._alpha is None:
            self._alpha = self._backward(self._beta[:self.n_points_])
        return self._alpha

    def __repr__(self) -> str:
        state = (f'{self.n_inputs_}->{self.n_outputs_}, {self.n_points_} points, length '
                 f'{self.length_:g}, noise {self.noise_:g}' if self._ready else 'unfitted')
        return f'ExactGP({state})'


def _scale(std: np.ndarray) -> np.ndarray:
    """Standard deviations with zeros (constant columns) replaced by 1."""
    return np.where(std > 0.0, std, 1.0)


register_kind(KIND, ExactGP.load)  # load(path) -> the model
