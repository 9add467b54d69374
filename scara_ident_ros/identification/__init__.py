"""Online identification core: joint-state samples in, a-priori effort predictions out.

Pure numpy, no rclpy: the ``identifier`` node converts messages, calls
:meth:`.session.IdentificationSession.process` (over one :class:`OnlineIdentifier` per
method) and publishes the :class:`SampleOutcome` it returns. What it is built from is
here too: the checks of a warm start (:mod:`.warm_start`) and the build for the first
valid sample's joints (:mod:`.lazy_core`), from the joint limits of
:mod:`scara_ident_ros.dynamics.joint_limits`.
Batch training takes its samples the same way: :mod:`.dataset` (samples through the same
input stage), :mod:`.recording` (from a bag), :mod:`.split` (the validation split);
:mod:`.metrics` is the one MSE and NMSE.
"""
from __future__ import annotations

from scara_ident_ros.identification.centred_differentiator import CentredDifferentiator
from scara_ident_ros.identification.differentiator import (DIFFERENTIATOR_WINDOW,
                                                           DIFFERENTIATORS, AccelerationEstimate,
                                                           Differentiator, make_differentiator)
from scara_ident_ros.identification.error_window import PAPER_WINDOW, ErrorWindow
from scara_ident_ros.identification.holdout import Holdout
from scara_ident_ros.identification.input_stage import Input, InputStage
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.metrics import ErrorStats, effort_errors
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.lazy_core import LazyCore, Skipped
from scara_ident_ros.identification.online_identifier import (Counts, OnlineIdentifier,
                                                              StepResult)
from scara_ident_ros.identification.reports import (ContactState, HealthFigures,
                                                    LearningFigures, MethodReport, SkipCounts,
                                                    StreamFigures)
from scara_ident_ros.identification.sample_outcome import Prediction, SampleOutcome
from scara_ident_ros.identification.sample_check import (DEFAULT_MAX_GAP_NS, Bounds, Sample,
                                                         SampleCheck)
from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.identification.reservoir_lm import ReservoirLM
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.identification.trainer import (TRAINERS, BackPropagation, Trainer,
                                                    make_trainer)
from scara_ident_ros.identification.warm_start import ModelMismatch, check_warm_start

__all__ = [
    'AccelerationEstimate', 'BackPropagation', 'Bounds', 'CentredDifferentiator', 'ContactState',
    'Counts', 'DEFAULT_MAX_GAP_NS', 'DIFFERENTIATORS', 'DIFFERENTIATOR_WINDOW', 'Differentiator',
    'ErrorStats', 'ErrorWindow', 'HealthFigures', 'Holdout', 'IdentifierSettings', 'Input',
    'InputStage', 'JointMap',
    'LazyCore', 'LearningFigures', 'MethodReport', 'ModelMismatch', 'OnlineIdentifier',
    'PAPER_WINDOW', 'Prediction', 'Reservoir', 'ReservoirLM', 'Sample', 'SampleCheck',
    'SampleOutcome', 'SkipCounts',
    'SkipReason', 'StreamFigures',
    'Skipped', 'StepResult', 'TRAINERS', 'Trainer', 'check_warm_start', 'effort_errors',
    'make_differentiator', 'make_trainer',
]
