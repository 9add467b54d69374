"""Hyperparameters of a squared-exponential (ARD) kernel, by the marginal likelihood of an
exact Gaussian process on a subset of the samples.

The kernel learners of the package (:mod:`scara_ident_ros.learners.sparse_spectrum_gp`)
approximate the GP with covariance::

    k(x, x') = s² exp(−½ Σ_i ((x_i − x'_i) / ℓ_i)²) + σ² δ(x, x')

on standardised inputs and outputs (each input column and each joint's effort scaled to
zero mean and unit variance). s² (signal variance), ℓ (one length scale per input: ARD) and
σ² (noise variance) are fitted here by maximising the log marginal likelihood of an exact GP
(scikit-learn's ``GaussianProcessRegressor``) on at most ``samples`` rows: O(samples³) per
likelihood evaluation, so 1000–2000 rows take seconds to a minute.

A group of joints shares one kernel (scikit-learn sums the likelihood over the outputs); one
group per joint gives each joint its own.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ['ArdHyperparameters', 'HYPER_SAMPLES', 'fit_ard_hyperparameters',
           'scale_hyperparameters']

#: Rows of the exact GP whose marginal likelihood is maximised (chosen at random).
HYPER_SAMPLES = 1500
_LENGTH_BOUNDS = (1e-1, 1e3)       # standardised input units
_SIGNAL_BOUNDS = (1e-3, 1e3)       # variance of the standardised effort
_NOISE_BOUNDS = (1e-6, 1.0)        # variance of the standardised effort
_NOISE_START = 1e-2


@dataclass(frozen=True)
class ArdHyperparameters:
    """One ARD kernel per group of joints, on standardised inputs and outputs.

    Attributes
    ----------
    length_scales : ndarray of shape (G, d)
        Length scale of each standardised input, per group.
    signal : ndarray of shape (G,)
        Signal variance s² (standardised effort units).
    noise : ndarray of shape (G,)
        Noise variance σ² (standardised effort units).
    """

    length_scales: np.ndarray
    signal: np.ndarray
    noise: np.ndarray


def fit_ard_hyperparameters(Xs: npt.ArrayLike, Ts: npt.ArrayLike, *, per_joint: bool,
                            samples: int = HYPER_SAMPLES, seed: int = 0
                            ) -> ArdHyperparameters:
    """Maximise an exact GP's marginal likelihood on at most ``samples`` rows.

    Parameters
    ----------
    Xs : array_like of shape (N, d)
        Standardised inputs.
    Ts : array_like of shape (N, n)
        Standardised efforts.
    per_joint : bool
        One kernel per joint (G = n) or one shared by all joints (G = 1).
    samples : int
        Rows used (drawn with ``seed`` without replacement when N is larger).
    seed : int
        Seed of the row draw and of the optimiser's start.

    Returns
    -------
    ArdHyperparameters
    """
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    x = np.asarray(Xs, dtype=np.float64)
    t = np.asarray(Ts, dtype=np.float64)
    if x.shape[0] > samples:
        rows = np.sort(np.random.default_rng(seed).choice(x.shape[0], samples, replace=False))
        x, t = x[rows], t[rows]
    d = x.shape[1]
    groups = [[j] for j in range(t.shape[1])] if per_joint else [list(range(t.shape[1]))]
    lengths, signal, noise = [], [], []
    for group in groups:
        kernel = (ConstantKernel(1.0, _SIGNAL_BOUNDS)
                  * RBF(np.full(d, np.sqrt(d)), _LENGTH_BOUNDS)
                  + WhiteKernel(_NOISE_START, _NOISE_BOUNDS))
        gp = GaussianProcessRegressor(kernel, normalize_y=False, random_state=seed)
        with warnings.catch_warnings():  # a length scale at its bound: an irrelevant input
            warnings.simplefilter('ignore', ConvergenceWarning)
            gp.fit(x, t[:, group] if len(group) > 1 else t[:, group[0]])
        fitted = gp.kernel_
        signal.append(float(fitted.k1.k1.constant_value))
        lengths.append(np.broadcast_to(fitted.k1.k2.length_scale, (d,)).astype(np.float64))
        noise.append(float(fitted.k2.noise_level))
    return ArdHyperparameters(np.array(lengths), np.array(signal), np.array(noise))


def scale_hyperparameters(d: int, n_groups: int, *, length_scale: float | None = None,
                          noise: float = _NOISE_START) -> ArdHyperparameters:
    """Hyperparameters from the data's scale alone (no fitting): every standardised input
    gets length ``length_scale`` (default √d, the typical distance between two samples),
    signal variance 1 (the standardised effort's) and noise variance ``noise``."""
    length = np.sqrt(d) if length_scale is None else float(length_scale)
    return ArdHyperparameters(np.full((n_groups, d), length), np.ones(n_groups),
                              np.full(n_groups, float(noise)))
