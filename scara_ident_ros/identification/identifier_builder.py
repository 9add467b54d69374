"""The one builder of an online identifier from settings: model, trainer, hold-out, checks.

What the ``identifier`` node runs (through :class:`~scara_ident_ros.identification.
lazy_core.LazyCore`), and what ``scara-ident``, the benchmarks and ``paper/`` run when they
stream a record through an identifier without a node: one :class:`~scara_ident_ros.
identification.identifier_settings.IdentifierSettings` (the node's defaults:
``IdentifierSettings.defaults()``) makes the model of its ``method`` (:func:`make_model`),
its trainer (:func:`make_learner`), the held-out blocks and the sample checks of the robot's
limits (:func:`build_identifier`)::

    settings = IdentifierSettings.defaults(method='ffs', seed=3)
    identifier = build_identifier(names, settings, limits)
    for sample in stream:
        identifier.process(...)
    identifier.model.save('ffs.npz')
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from scara_ident_ros.learners.hybrid_model import HybridModel, online_hybrid
from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.estimator import Estimator
from scara_ident_ros.identification.background_estimator import BackgroundEstimator
from scara_ident_ros.identification.learner_process import LearnerClient
from scara_ident_ros.identification.differentiator import (AccelerationEstimate,
                                                           make_differentiator)
from scara_ident_ros.identification.holdout import Holdout
from scara_ident_ros.identification.hybrid_trainer import HybridTrainer
from scara_ident_ros.identification.input_stage import InputStage
from scara_ident_ros.identification.estimator_learner import EstimatorLearner
from scara_ident_ros.identification.learner_methods import (LEARNER_METHODS,
                                                             make_learner_model)
from scara_ident_ros.identification.online_identifier import OnlineIdentifier
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.parameters import PHYSICAL_METHODS
from scara_ident_ros.identification.rls_trainer import RecursiveLeastSquaresTrainer
from scara_ident_ros.identification.sample_check import Bounds, joint_bounds
from scara_ident_ros.identification.streamed_estimator import ArrayLearner, StreamedEstimator
from scara_ident_ros.identification.trainer import (Trainer, make_trainer,
                                                    starts_with_friction_steps)
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.presets import make_network

__all__ = ['background_learner', 'build_identifier', 'make_learner',
           'make_model']


def make_model(names: Sequence[str], settings: IdentifierSettings, limits: JointLimits | None, *,
               urdf: str = '', urdf_source: str = 'robot_description',
               physical: PhysicalModel | None = None) -> Estimator:
    """A fresh model of ``settings.method`` for the joints ``names``.

    A network (``ffs``, ``ffw``, ``ffmw``) is scaled by ``limits`` (of ``names``).
    ``physical``: the URDF's rigid-body model with friction and rotor inertia, from the
    URDF's own inertias (RLS's prior). ``kernel``, ``gp``: a fresh learner
    (:func:`~scara_ident_ros.identification.learner_methods.make_learner_model`), which
    :func:`build_identifier` streams. ``hybrid``: that plus an FFS network of its residual,
    starting at zero output, its outputs scaled to ``RESIDUAL_SHARE`` of the effort limits
    (a residual is a fraction of the effort:
    :func:`~scara_ident_ros.learners.hybrid_model.online_hybrid`). The physical part is
    ``physical`` if given (e.g. with another friction law), else built from ``urdf``.
    """
    s = settings
    names = list(names)
    if s.method in LEARNER_METHODS:
        return make_learner_model(s.method, kernel_features=s.kernel_features,
                                  gp_budget=s.gp_budget, warmup=s.learner_warmup,
                                  seed=s.seed)
    if s.method in PHYSICAL_METHODS:
        if physical is None:
            physical = PhysicalModel(urdf, joint_names=names, source=urdf_source)
        if s.method == 'physical':
            physical.set_theta(physical.urdf_parameters())
            return physical
        assert limits is not None, 'a hybrid network is scaled by the joint limits'
        return online_hybrid(physical, limits.select(names).scaling(),
                             n_hidden=s.hidden_units, seed=s.seed,
                             friction_steps=s.lm_friction_steps)
    assert limits is not None, 'a network is scaled by the joint limits'
    ffmw = s.method == 'ffmw'
    network = make_network(
        s.method, len(names), n_hidden=s.hidden_units, seed=s.seed,
        learning_rate=s.learning_rate or None,
        momentum=s.momentum if s.momentum >= 0 else None,
        k=s.k if ffmw else None, a=s.a if ffmw else None, b=s.b if ffmw else None,
        friction_steps=starts_with_friction_steps(s.trainer, s.lm_friction_steps))
    network.set_scaling(*limits.select(names).scaling())
    return network


def make_learner(model: Estimator, settings: IdentifierSettings, *,
                 background: bool = False) -> Trainer:
    """The trainer of ``model``, a model of ``settings.method``: RLS for ``physical``, RLS
    and the network's trainer for ``hybrid``, ``settings.trainer`` for a network
    (``background``: ``lm`` in a learner process of its own, :class:`~scara_ident_ros.
    identification.background_lm.BackgroundLM`), the learner's ``partial_fit`` in batches
    of ``learner_batch`` for ``kernel`` and ``gp`` (a :class:`~scara_ident_ros.
    identification.streamed_estimator.StreamedEstimator`; ``background``: in a process of
    its own, :class:`~scara_ident_ros.identification.background_estimator.
    BackgroundEstimator`)."""
    s = settings
    if s.method in LEARNER_METHODS:
        stream = cast(StreamedEstimator, model)
        if background:
            return BackgroundEstimator(stream, batch=s.learner_batch, warmup=s.learner_warmup,
                                       reservoir_size=s.reservoir_size, seed=s.seed,
                                       label=s.method)
        return EstimatorLearner(stream, batch=s.learner_batch, warmup=s.learner_warmup,
                                reservoir_size=s.reservoir_size, seed=s.seed)

    def trainer_of(net: FeedForwardNet, hybrid: HybridModel | None = None) -> Trainer:
        return make_trainer(s.trainer, net, reservoir_size=s.reservoir_size,
                            lm_interval=s.lm_interval, lm_steps=s.lm_steps, seed=s.seed,
                            lm_float64=s.lm_float64, lm_slow_share=s.lm_slow_share,
                            background=background, lm_nice=s.lm_nice, label=f'lm-{s.method}',
                            hybrid=hybrid)

    # The method fixes the model's class: a warm start was checked to be the method's
    # (``warm_start.check_warm_start``), a fresh model is made by it (:func:`make_model`).
    if s.method == 'physical':
        return RecursiveLeastSquaresTrainer(cast(PhysicalModel, model))
    if s.method == 'hybrid':
        hybrid = cast(HybridModel, model)
        return HybridTrainer(hybrid, trainer_of(hybrid.network, hybrid), seed=s.seed)
    return trainer_of(cast(FeedForwardNet, model))


def build_identifier(names: Sequence[str], settings: IdentifierSettings,
                     limits: JointLimits | None = None, *, model: Estimator | None = None,
                     urdf: str = '', urdf_source: str = 'robot_description',
                     physical: PhysicalModel | None = None,
                     differentiator: AccelerationEstimate | None = None,
                     bounds: Bounds | None = None, stage: InputStage | None = None,
                     background: bool = False) -> OnlineIdentifier:
    """An online identifier of ``settings`` for the joints ``names``, as the node builds it.

    Parameters
    ----------
    names : sequence of str
        The joints, in the order of the model's inputs and outputs.
    settings : IdentifierSettings
        Method, trainer, hold-out, checks (``IdentifierSettings.defaults()``: the node's).
    limits : JointLimits, optional
        Scale a fresh network; bound the samples (``settings.limit_margin``) if they name
        every joint of ``names``.
    model : Estimator, optional
        A model of ``settings.method`` to go on learning (a warm start); else
        :func:`make_model` (with ``urdf``, ``urdf_source``, ``physical``).
    differentiator : AccelerationEstimate, optional
        The q'' estimate; default that of ``settings`` (``differentiator``, ``window``,
        ``cutoff_hz``).
    bounds : Bounds, optional
        The sample checks' bounds instead of those of ``limits``.
    stage : InputStage, optional
        An input stage shared with other identifiers (see :class:`OnlineIdentifier`).
    background : bool
        ``lm`` learns in a process of its own.

    Returns
    -------
    OnlineIdentifier
        Its ``model`` has ``metadata`` ``joint_names`` and ``method``; its ``trainer`` may
        run a process (close it: ``BackgroundLM.close``).
    """
    names = list(names)
    if model is None:
        model = make_model(names, settings, limits, urdf=urdf, urdf_source=urdf_source,
                           physical=physical)
    if settings.method in LEARNER_METHODS:  # predicts from the first sample
        model = StreamedEstimator(cast(ArrayLearner, model), len(names))
    model.metadata['joint_names'] = np.array(names)
    model.metadata['method'] = np.array(settings.method)
    if bounds is None and limits is not None and not limits.missing(names):
        bounds = joint_bounds(limits.select(names), settings.limit_margin)
    n = len(names)
    holdout = (Holdout(3 * n, n, fraction=settings.validation_fraction,
                       block=settings.validation_block, seed=settings.seed)
               if settings.validation_fraction > 0 else None)
    if differentiator is None:
        differentiator = make_differentiator(settings.differentiator, window=settings.window,
                                             cutoff_hz=settings.cutoff_hz)
    trainer = make_learner(model, settings, background=background)
    return OnlineIdentifier(
        model, joint_names=names, differentiator=differentiator, trainer=trainer,
        holdout=holdout, mse_window=settings.mse_window, learn=settings.learn,
        max_gap_ns=round(settings.max_gap * 1e9), bounds=bounds, stage=stage,
        derive_velocity=settings.derive_velocity == 'auto',
        learner=background_learner(trainer))


def background_learner(trainer: Trainer | None) -> LearnerClient | None:
    """The learner process of an identifier's ``trainer`` (a hybrid's: its network's), or
    None if it learns in the caller's process."""
    if isinstance(trainer, HybridTrainer):
        trainer = trainer.network
    return trainer if isinstance(trainer, LearnerClient) else None
