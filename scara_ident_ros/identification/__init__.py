"""Online identification core: joint-state samples in, a-priori effort predictions out.

Pure numpy, no rclpy: the ``identifier`` node converts messages and calls
:meth:`OnlineIdentifier.process`.
"""
from __future__ import annotations

from scara_ident_ros.identification.differentiator import METHODS, Differentiator
from scara_ident_ros.identification.error_window import PAPER_WINDOW, ErrorStats, ErrorWindow
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.online_identifier import (Counts, EffortModel,
                                                              OnlineIdentifier, StepResult)
from scara_ident_ros.identification.sample_check import (DEFAULT_MAX_GAP_NS, Sample,
                                                         SampleCheck)
from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = [
    'Counts', 'DEFAULT_MAX_GAP_NS', 'Differentiator', 'EffortModel', 'ErrorStats', 'ErrorWindow',
    'JointMap', 'METHODS', 'OnlineIdentifier', 'PAPER_WINDOW', 'Sample', 'SampleCheck',
    'SkipReason', 'StepResult',
]
