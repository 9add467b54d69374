"""Sparse-spectrum Gaussian-process regression with random Fourier features, learnt offline
in one solve or online sample by sample (I-SSGPR, Gijsberts & Metta 2013).

The squared-exponential kernel with one length scale per input (ARD,
:mod:`scara_ident_ros.learners.ard_hyperparameters`) is the expectation of
cos(ωᵀ(u − u')) over frequencies ω ~ N(0, diag(ℓ)⁻²) (Bochner's theorem). With m frequencies
drawn once (seeded), the D = 2m features::

    z(x) = m^(−1/2) [cos(Ω u), sin(Ω u)],   u = (x − x_mean) / x_scale   (standardised)

make the GP a Bayesian linear model t = z(x)ᵀ w + noise, w ~ N(0, s² I), noise ~ N(0, σ²),
with t the standardised effort. Its posterior mean weights solve::

    A W = B,   A = ZᵀZ + (σ²/s²) I  (D, D),   B = Zᵀ T  (D, n)

and the predictive variance of an effort is σ² (1 + z(x)ᵀ A⁻¹ z(x)) (times the effort's
scale²). Features are shared by the joints of a group (one kernel, one A, weights per
joint); ``per_joint=True`` makes one group per joint (n kernels, n times the cost).

Online (``partial_fit``), each sample is predicted, then learnt by the recursive
least-squares update of P = A⁻¹ (Sherman–Morrison: two O(D²) operations, no solve)::

    k = P z / (1 + zᵀ P z),   W ← W + k (t − zᵀ W),   P ← P − k (P z)ᵀ

which is the batch solution exactly (in exact arithmetic). I-SSGPR updates a Cholesky factor
of A instead; numpy and scipy have no rank-1 Cholesky update and a Python loop over its D
columns costs about a millisecond, so here the inverse is updated and, against round-off,
recomputed from the exactly accumulated A and B every ``refresh`` samples (one Cholesky,
O(D³), amortised). ``fit`` is that batch solve on all samples.

Measured (benchmarks/realdata.md, docs/results.md): an online update of 7 joints costs about
0.4, 0.6 and 1.2 ms at D = 300, 500, 1000 on one core of a loaded machine (load 8); on the
WAM's published split the features approximate the exact GP's short kernel poorly (SMSE 0.04
at D = 2000 where the exact GP reaches 8e-5), so offline, up to ~15,000 samples, prefer the
exact GP. The marginal likelihood (``hyperparameters='gp'``) can choose a kernel smoother
than validation would on sparse subsets (the WAM's: 0.044 against 8e-5 for the exact GP).
"""
from __future__ import annotations

import operator
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.linalg import LinAlgError, cho_factor, cho_solve
from scipy.linalg.blas import dsymv, dsyr

from scara_ident_ros.estimator import SavedEstimator, check_samples, register_kind
from scara_ident_ros.learners.ard_hyperparameters import (HYPER_SAMPLES, ArdHyperparameters,
                                                          fit_ard_hyperparameters,
                                                          scale_hyperparameters)
from scara_ident_ros.nn.errors import ModelFormatError

__all__ = ['HYPERPARAMETER_SOURCES', 'KIND', 'N_FEATURES', 'REFRESH', 'SparseSpectrumGP']

KIND = 'kernel'  #: the model file's kind
N_FEATURES = 500  #: default number of features D (D/2 random frequencies)
REFRESH = 1000  #: samples between recomputations of A⁻¹ and W from A and B
#: Where the kernel's hyperparameters come from: the marginal likelihood of an exact GP on
#: a subset, or the data's scale alone.
HYPERPARAMETER_SOURCES = ('gp', 'scale')
_CHUNK = 4096  # rows per block when accumulating ZᵀZ
_FLOAT_ARRAYS = ('x_mean', 'x_scale', 'y_mean', 'y_scale', 'length_scales', 'signal',
                 'noise', 'omega', 'gram', 'moment')


class SparseSpectrumGP(SavedEstimator):
    """Sparse-spectrum GP regression (random Fourier features) of joint efforts.

    Parameters
    ----------
    n_features : int, default 500
        Number of features D (even: D/2 frequencies, each a cosine and a sine).
    per_joint : bool, default False
        One kernel (features, A) per joint instead of one shared by all joints.
    hyperparameters : {'gp', 'scale'}, default 'gp'
        'gp': length scales, signal and noise variance by maximising the marginal
        likelihood of an exact GP on ``hyper_samples`` rows of the first data
        (:func:`~scara_ident_ros.learners.ard_hyperparameters.fit_ard_hyperparameters`);
        'scale': from the data's scale alone (length √d on standardised inputs, noise
        ``noise``).
    hyper_samples : int, default 1500
        Rows of the exact GP (see ``hyperparameters``).
    noise : float, default 0.01
        Noise variance of the standardised effort with ``hyperparameters='scale'``.
    refresh : int, default 1000
        Online: samples between recomputations of A⁻¹ and W from the accumulated A and B.
    seed : int, default 0
        Seed of the frequencies and of the hyperparameters' row draw.

    Attributes
    ----------
    n_inputs_, n_outputs_ : int
        d = 3n and n, set by the first data.
    x_mean_, x_scale_ : ndarray of shape (d,)
        Input standardisation.
    y_mean_, y_scale_ : ndarray of shape (n,)
        Effort standardisation (N·m, N).
    hyper_ : ArdHyperparameters
        The kernel of each group (standardised units).
    omega_ : ndarray of shape (G, D/2, d)
        Frequencies on standardised inputs (ℓ included).
    gram_ : ndarray of shape (G, D, D)
        A = ZᵀZ + (σ²/s²) I over the samples learnt.
    moment_ : ndarray of shape (G, D, n/G)
        B = ZᵀT.
    n_samples_ : int
        Samples learnt.
    metadata : dict of str to ndarray
        Saved with the model (joint names, method, ...).
    """

    kind = KIND

    def __init__(self, n_features: int = N_FEATURES, *, per_joint: bool = False,
                 hyperparameters: str = 'gp', hyper_samples: int = HYPER_SAMPLES,
                 noise: float = 1e-2, refresh: int = REFRESH, seed: int = 0) -> None:
        n_features = operator.index(n_features)
        if n_features < 2 or n_features % 2:
            raise ValueError(f'n_features must be even and at least 2, got {n_features}')
        if hyperparameters not in HYPERPARAMETER_SOURCES:
            raise ValueError(f'hyperparameters must be one of {HYPERPARAMETER_SOURCES}, '
                             f'got {hyperparameters!r}')
        if operator.index(hyper_samples) < 2 or operator.index(refresh) < 1:
            raise ValueError('need hyper_samples >= 2 and refresh >= 1')
        if not noise > 0.0:
            raise ValueError(f'noise must be positive, got {noise}')
        self.n_features = n_features
        self.per_joint = bool(per_joint)
        self.hyperparameters = hyperparameters
        self.hyper_samples = int(hyper_samples)
        self.noise = float(noise)
        self.refresh = int(refresh)
        self.seed = int(seed)
        self.metadata: dict[str, np.ndarray] = {}
        self.n_samples_ = 0
        self._ready = False
        self._inverse = np.zeros((0, 0, 0))   # P = A⁻¹ per group (G, D, D)
        self._weights = np.zeros((0, 0, 0))   # W = A⁻¹ B per group (G, D, n/G)
        self._triangle_only = False           # only P's lower triangle is current
        self._pending: list[int] = []          # rows of this partial_fit not yet in A, B
        self._pending_rows: list[tuple[np.ndarray, np.ndarray]] = []  # earlier calls' rows
        self._unfolded = 0                     # rows learnt since A⁻¹ was last recomputed
        self._inverse_due = False              # W is current, P = A⁻¹ not computed yet

    # ----------------------------------------------------------------- estimator contract
    def get_params(self) -> dict[str, Any]:
        """The constructor's hyperparameters, as data."""
        return {'n_features': self.n_features, 'per_joint': self.per_joint,
                'hyperparameters': self.hyperparameters,
                'hyper_samples': self.hyper_samples, 'noise': self.noise,
                'refresh': self.refresh, 'seed': self.seed}

    def fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> SparseSpectrumGP:
        """Learn the batch solution from samples X (N, 3n) and efforts Y (N, n).

        The standardisation and kernel come from these samples (unless
        :meth:`set_kernel` gave them); whatever was learnt before is forgotten.
        """
        x, y = self._check(X, Y, first=True)
        if not self._ready:
            self.set_kernel(x, y)
        self._reset_statistics()
        for start in range(0, x.shape[0], _CHUNK):
            self._accumulate(x[start:start + _CHUNK], y[start:start + _CHUNK])
        self._solve()
        return self

    def partial_fit(self, X: npt.ArrayLike, Y: npt.ArrayLike) -> np.ndarray:
        """Predict each sample, then learn it (recursive least squares, module docstring).

        The first call sets the standardisation and kernel from its samples (at least 2
        rows) unless :meth:`fit` or :meth:`set_kernel` did.

        Returns
        -------
        ndarray of shape (N, n)
            Each sample's prediction made before it was learnt (N·m, N).
        """
        x, y = self._check(X, Y, first=not self._ready)
        if not self._ready:
            self.set_kernel(x, y)
            self._reset_statistics()
        if self._inverse_due:
            self._solve()
        z = self._features(x)                       # (G, N, D)
        t = (y - self.y_mean_) / self.y_scale_      # (N, n)
        prediction = np.empty_like(t)
        k_out = self._k_out
        for i in range(x.shape[0]):
            for g in range(self._groups):
                zi = z[g, i]
                w = self._weights[g]
                ti = t[i, g * k_out:(g + 1) * k_out]
                prediction[i, g * k_out:(g + 1) * k_out] = zi @ w
                # P is symmetric: BLAS keeps one triangle (that of P.T, F-ordered, in place)
                upper = self._inverse[g].T
                pz = dsymv(1.0, upper, zi, lower=0)
                scale = 1.0 / (1.0 + zi @ pz)
                w += np.outer(scale * pz, ti - zi @ w)
                dsyr(-scale, pz, a=upper, lower=0, overwrite_a=1)
                self._triangle_only = True
            self._pending.append(i)
            self.n_samples_ += 1
            self._unfolded += 1
            if self._unfolded >= self.refresh:
                self._fold(z, t)
        if self._pending:  # keep the rows until the next refresh
            rows = np.asarray(self._pending, dtype=np.int64)
            self._pending_rows.append((z[:, rows], t[rows]))
            self._pending = []
        return prediction * self.y_scale_ + self.y_mean_

    def predict(self, X: npt.ArrayLike) -> np.ndarray:
        """Efforts (N, n) for inputs X (N, 3n) (N·m, N)."""
        return self._predict(X, return_std=False)[0]

    def predict_std(self, X: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Efforts (N, n) for inputs X (N, 3n) and their predictive standard deviation
        (N, n), noise included (O(D²) per sample; N·m, N)."""
        return self._predict(X, return_std=True)

    def _predict(self, X: npt.ArrayLike, *, return_std: bool
                 ) -> tuple[np.ndarray, np.ndarray]:
        self._need_ready()
        x = self._check_x(X)
        z = self._features(x)
        k_out = self._k_out
        out = np.empty((x.shape[0], self.n_outputs_))
        std = np.empty_like(out) if return_std else out
        for g in range(self._groups):
            out[:, g * k_out:(g + 1) * k_out] = z[g] @ self._weights[g]
            if return_std:
                self._full_inverse()
                spread = np.einsum('nd,de,ne->n', z[g], self._inverse[g], z[g])
                var = self.hyper_.noise[g] * (1.0 + spread)
                std[:, g * k_out:(g + 1) * k_out] = np.sqrt(var)[:, None]
        return out * self.y_scale_ + self.y_mean_, std * self.y_scale_

    # ------------------------------------------------------------------ state and kernel
    def set_kernel(self, X: npt.ArrayLike, Y: npt.ArrayLike,
                   hyper: ArdHyperparameters | None = None) -> SparseSpectrumGP:
        """Set the standardisation from X (N, 3n) and Y (N, n), the kernel (``hyper``, or
        as ``hyperparameters`` says) and draw the frequencies; forgets what was learnt."""
        x, y = self._check(X, Y, first=True)
        self.n_inputs_, self.n_outputs_ = x.shape[1], y.shape[1]
        self.x_mean_ = x.mean(axis=0)
        self.x_scale_ = _scale(x.std(axis=0))
        self.y_mean_ = y.mean(axis=0)
        self.y_scale_ = _scale(y.std(axis=0))
        groups = self.n_outputs_ if self.per_joint else 1
        if hyper is None:
            if self.hyperparameters == 'gp' and x.shape[0] >= 2:
                hyper = fit_ard_hyperparameters(
                    (x - self.x_mean_) / self.x_scale_, (y - self.y_mean_) / self.y_scale_,
                    per_joint=self.per_joint, samples=self.hyper_samples, seed=self.seed)
            else:
                hyper = scale_hyperparameters(x.shape[1], groups, noise=self.noise)
        if hyper.length_scales.shape != (groups, x.shape[1]):
            raise ValueError(f'need length scales of shape {(groups, x.shape[1])}, '
                             f'got {hyper.length_scales.shape}')
        self.hyper_ = hyper
        rng = np.random.default_rng(self.seed)
        base = rng.standard_normal((groups, self.n_features // 2, x.shape[1]))
        self.omega_ = base / hyper.length_scales[:, None, :]
        self._ready = True
        self._reset_statistics()
        return self

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The entries that :meth:`from_arrays` rebuilds the model from."""
        self._need_ready()
        self._fold_pending()
        return {'params': np.array([self.n_features, self.hyper_samples, self.refresh,
                                    self.seed], np.int64),
                'per_joint': np.array(self.per_joint),
                'hyperparameters': np.array(self.hyperparameters),
                'noise_default': np.array(self.noise),
                'n_samples': np.array(self.n_samples_, np.int64),
                'x_mean': self.x_mean_, 'x_scale': self.x_scale_, 'y_mean': self.y_mean_,
                'y_scale': self.y_scale_, 'length_scales': self.hyper_.length_scales,
                'signal': self.hyper_.signal, 'noise': self.hyper_.noise,
                'omega': self.omega_, 'gram': self.gram_, 'moment': self.moment_,
                'weights': self._weights}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], *, source: str) -> SparseSpectrumGP:
        """Rebuild a model from :meth:`to_arrays`' entries. With ``weights`` (W = A⁻¹B as
        saved) it predicts at once and solves for A⁻¹ only when it learns again (what a
        learner process hands to the message path costs no O(D³) solve there); files
        without them are solved now.

        Raises
        ------
        ModelFormatError
            If an entry is missing, has the wrong type or shape, or A is not positive
            definite.
        """
        try:
            n_features, hyper_samples, refresh, seed = (int(v) for v in arrays['params'])
            model = cls(n_features, per_joint=bool(arrays['per_joint']),
                        hyperparameters=str(arrays['hyperparameters']),
                        hyper_samples=hyper_samples, noise=float(arrays['noise_default']),
                        refresh=refresh, seed=seed)
            values = {name: np.asarray(arrays[name]) for name in _FLOAT_ARRAYS}
            for name, value in values.items():
                if value.dtype != np.float64 or not np.all(np.isfinite(value)):
                    raise ValueError(f'{name} must be finite float64')
            groups, half, d = values['omega'].shape
            n = values['y_mean'].shape[0]
            expected = {'x_mean': (d,), 'x_scale': (d,), 'y_scale': (n,),
                        'length_scales': (groups, d), 'signal': (groups,),
                        'noise': (groups,), 'gram': (groups, 2 * half, 2 * half),
                        'moment': (groups, 2 * half, n // groups)}
            for name, shape in expected.items():
                if values[name].shape != shape:
                    raise ValueError(f'{name} has shape {values[name].shape}, not {shape}')
            if 2 * half != n_features or groups != (n if model.per_joint else 1):
                raise ValueError('the frequencies do not match n_features and per_joint')
            model.n_inputs_, model.n_outputs_ = d, n
            model.x_mean_, model.x_scale_ = values['x_mean'], values['x_scale']
            model.y_mean_, model.y_scale_ = values['y_mean'], values['y_scale']
            model.hyper_ = ArdHyperparameters(values['length_scales'], values['signal'],
                                              values['noise'])
            model.omega_ = values['omega']
            model._ready = True
            model._reset_statistics()
            model.gram_, model.moment_ = values['gram'].copy(), values['moment'].copy()
            model.n_samples_ = int(arrays['n_samples'])
            weights = np.asarray(arrays['weights']) if 'weights' in arrays else None
            if weights is None:
                model._solve()
            elif (weights.dtype != np.float64 or weights.shape != model.moment_.shape
                  or not np.all(np.isfinite(weights))):
                raise ValueError(f'weights must be finite float64 of shape '
                                 f'{model.moment_.shape}')
            else:
                model._weights = weights.copy()
                model._inverse_due = True
        except (KeyError, ValueError, TypeError, LinAlgError) as exc:
            raise ModelFormatError(f'{source}: corrupt kernel model: '
                                   f'{" ".join(str(exc).split())}') from None
        return model

    # ------------------------------------------------------------------------- internals
    @property
    def _groups(self) -> int:
        return int(self.omega_.shape[0])

    @property
    def _k_out(self) -> int:
        return self.n_outputs_ // self._groups

    def _need_ready(self) -> None:
        if not self._ready:
            raise RuntimeError('the model has learnt nothing yet: call fit or partial_fit')

    def _check_x(self, X: npt.ArrayLike) -> np.ndarray:
        x = np.asarray(X, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_inputs_:
            raise ValueError(f'X must have shape (N, {self.n_inputs_}), got {x.shape}')
        if not np.all(np.isfinite(x)):
            raise ValueError('X must be finite')
        return x

    def _check(self, X: npt.ArrayLike, Y: npt.ArrayLike, *, first: bool
               ) -> tuple[np.ndarray, np.ndarray]:
        return check_samples(X, Y, None if first else (self.n_inputs_, self.n_outputs_))

    def _features(self, x: np.ndarray) -> np.ndarray:
        """Features (G, N, D) of physical inputs x (N, d)."""
        u = (x - self.x_mean_) / self.x_scale_
        phase = np.einsum('gmd,nd->gnm', self.omega_, u)
        return np.concatenate([np.cos(phase), np.sin(phase)], axis=2) / np.sqrt(
            self.n_features // 2)

    def _ridge(self) -> np.ndarray:
        """σ²/s² per group (G,)."""
        return np.asarray(self.hyper_.noise / self.hyper_.signal, dtype=np.float64)

    def _reset_statistics(self) -> None:
        groups, dim = self._groups, self.n_features
        eye = np.eye(dim)
        ridge = self._ridge()
        self.gram_ = ridge[:, None, None] * eye
        self.moment_ = np.zeros((groups, dim, self._k_out))
        self._inverse = eye / ridge[:, None, None]
        self._triangle_only = False
        self._weights = np.zeros((groups, dim, self._k_out))
        self._pending = []
        self._pending_rows = []
        self._unfolded = 0
        self._inverse_due = False
        self.n_samples_ = 0

    def _accumulate(self, x: np.ndarray, y: np.ndarray) -> None:
        """Add samples to A and B (no solve)."""
        z = self._features(x)
        t = (y - self.y_mean_) / self.y_scale_
        self._add(z, t)
        self.n_samples_ += x.shape[0]

    def _add(self, z: np.ndarray, t: np.ndarray) -> None:
        k_out = self._k_out
        for g in range(self._groups):
            self.gram_[g] += z[g].T @ z[g]
            self.moment_[g] += z[g].T @ t[:, g * k_out:(g + 1) * k_out]

    def _fold(self, z: np.ndarray, t: np.ndarray) -> None:
        """Add the rows learnt online since the last refresh to A and B; re-solve."""
        for zs, ts in self._pending_rows:
            self._add(zs, ts)
        self._pending_rows = []
        rows = np.asarray(self._pending, dtype=np.int64)
        self._add(z[:, rows], t[rows])
        self._pending = []
        self._unfolded = 0
        self._solve()

    def _fold_pending(self) -> None:
        if self._pending_rows:
            for zs, ts in self._pending_rows:
                self._add(zs, ts)
            self._pending_rows = []
            self._unfolded = 0
            self._solve()

    def _full_inverse(self) -> None:
        """Mirror the triangle of P that the recursive update keeps (its lower, C order)."""
        if self._inverse_due:
            self._solve()
        if self._triangle_only:
            for g in range(self._groups):
                lower = np.tril(self._inverse[g])
                self._inverse[g] = lower + np.tril(lower, -1).T
            self._triangle_only = False

    def _solve(self) -> None:
        """W = A⁻¹ B and P = A⁻¹ from the accumulated A, B (Cholesky)."""
        eye = np.eye(self.n_features)
        for g in range(self._groups):
            factor = cho_factor(self.gram_[g], lower=True, check_finite=False)
            self._weights[g] = cho_solve(factor, self.moment_[g], check_finite=False)
            self._inverse[g] = cho_solve(factor, eye, check_finite=False)
        self._triangle_only = False
        self._inverse_due = False

    def __repr__(self) -> str:
        state = (f'{self.n_inputs_}->{self.n_outputs_}, {self.n_samples_} samples'
                 if self._ready else 'unfitted')
        return (f'SparseSpectrumGP(n_features={self.n_features}, '
                f'per_joint={self.per_joint}, {state})')


def _scale(std: np.ndarray) -> np.ndarray:
    """Standard deviations with zeros (constant columns) replaced by 1."""
    return np.where(std > 0.0, std, 1.0)


register_kind(KIND, SparseSpectrumGP.load)  # load(path) -> the model
