"""Online identification core: joint-state samples in, a-priori effort predictions out.

Pure numpy, no rclpy: the ``identifier`` node converts messages and calls
:meth:`OnlineIdentifier.process`.
"""
from __future__ import annotations

from scara_ident_ros.identification.centred_differentiator import CentredDifferentiator
from scara_ident_ros.identification.differentiator import METHODS, Differentiator
from scara_ident_ros.identification.error_window import PAPER_WINDOW, ErrorStats, ErrorWindow
from scara_ident_ros.identification.holdout import Holdout
from scara_ident_ros.identification.input_stage import (DIFFERENTIATORS, AccelerationEstimate,
                                                        Input, InputStage, make_differentiator)
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.online_identifier import (Counts, EffortModel,
                                                              OnlineIdentifier, StepResult)
from scara_ident_ros.identification.sample_check import (DEFAULT_MAX_GAP_NS, Bounds, Sample,
                                                         SampleCheck)
from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.identification.trainer import (TRAINERS, BackPropagation, ReservoirLM,
                                                    Trainer, make_trainer)

__all__ = [
    'AccelerationEstimate', 'BackPropagation', 'Bounds', 'CentredDifferentiator', 'Counts',
    'DEFAULT_MAX_GAP_NS', 'DIFFERENTIATORS', 'Differentiator', 'EffortModel', 'ErrorStats',
    'ErrorWindow', 'Holdout', 'Input', 'InputStage', 'JointMap', 'METHODS', 'OnlineIdentifier',
    'PAPER_WINDOW', 'Reservoir', 'ReservoirLM', 'Sample', 'SampleCheck', 'SkipReason',
    'StepResult', 'TRAINERS', 'Trainer', 'make_differentiator', 'make_trainer',
]
