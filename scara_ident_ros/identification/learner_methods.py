"""The learners as identifier methods: ``kernel``, ``gp`` and ``linear``, and their fresh models.

An identifier's ``method`` is a network (``ffs``, ``ffw``, ``ffmw``), a model of the robot's
URDF (``physical``, ``hybrid``) or one of these learners, which need neither the URDF nor
the joint limits (they standardise their inputs and efforts with their first data):

``kernel``
    :class:`~scara_ident_ros.learners.sparse_spectrum_gp.SparseSpectrumGP`: sparse-spectrum
    GP regression, ``kernel_features`` random features, updated sample by sample (I-SSGPR).
``gp``
    :class:`~scara_ident_ros.learners.exact_gp.ExactGP`: exact GP regression with at most
    ``gp_budget`` points.
``linear``
    :class:`~scara_ident_ros.learners.linear_features.LinearFeatures`: least squares on
    [q, q', q'', sin q, cos q, tanh(q'/0.05), 1], its batch solution after every call: the
    baseline, and on TIAGo the best learner (``scara-ident train --method auto``).

All learn through their ``partial_fit`` (the estimator contract), in batches of
``learner_batch`` samples: :mod:`~scara_ident_ros.identification.estimator_learner`.
"""
from __future__ import annotations

from scara_ident_ros.estimator import OnlineEstimator
from scara_ident_ros.learners.exact_gp import BUDGET

__all__ = ['GP_BUDGET', 'KERNEL_FEATURES', 'KERNEL_HYPERPARAMETERS', 'LEARNER_BATCH',
           'LEARNER_METHODS', 'LEARNER_WARMUP', 'make_learner_model']

#: The methods whose model is a learner (no URDF, no joint limits needed).
LEARNER_METHODS = ('kernel', 'gp', 'linear')
KERNEL_FEATURES = 500  #: default random features D of ``kernel`` (0.05-0.1 ms per sample)
#: Where ``kernel``'s hyperparameters come from online (``SparseSpectrumGP``'s
#: ``hyperparameters``): 'gp' (ARD marginal likelihood on the warm-up) costs 30-40 s once
#: in the learner's first call; 'scale' (length √d on standardised inputs, noise 0.01)
#: costs nothing, and scored alike on TIAGo online (benchmarks/online_real.md).
KERNEL_HYPERPARAMETERS = 'scale'
GP_BUDGET = BUDGET  #: default most points of ``gp``: ExactGP's own (its factor: budget² doubles)
#: Default samples per ``partial_fit`` call of a learner: 1 learns each sample as it
#: comes (the estimator's own a-priori predictions); more amortise a call's overhead and
#: let a learner process keep up.
LEARNER_BATCH = 50
#: Samples gathered before a learner's first ``partial_fit``: its standardisation and
#: kernel come from them (1 s at 1 kHz); predicted meanwhile by their running mean.
LEARNER_WARMUP = 1000


def make_learner_model(method: str, *, kernel_features: int = KERNEL_FEATURES,
                       gp_budget: int = GP_BUDGET, warmup: int = LEARNER_WARMUP,
                       seed: int = 0) -> OnlineEstimator:
    """A fresh, unfitted learner of ``method`` (one of :data:`LEARNER_METHODS`).

    ``kernel_features``: D of ``kernel``; ``gp_budget``: the most points of ``gp``
    (its warm-up is ``warmup`` rows, at most the budget; it chooses its kernel on
    validation blocks of them, so at least 500); ``seed``: the
    kernel's frequencies.

    Raises
    ------
    ValueError
        For another method, or sizes the learner refuses.
    """
    from scara_ident_ros.learners import ExactGP, LinearFeatures, SparseSpectrumGP

    if method == 'linear':
        return LinearFeatures()
    if method == 'kernel':
        return SparseSpectrumGP(kernel_features, hyperparameters=KERNEL_HYPERPARAMETERS,
                                seed=seed)
    if method == 'gp':
        return ExactGP(budget=gp_budget, warmup=min(warmup, gp_budget))
    raise ValueError(f'{method!r} is not a learner method ({", ".join(LEARNER_METHODS)})')
