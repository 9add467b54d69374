"""Feed-forward networks of the paper (FFS, FFW, FFMW) and their training, in pure numpy.

Nothing here imports rclpy: nodes convert messages to arrays and call these.
"""
from __future__ import annotations

from scara_ident_ros.nn.activations import (ACTIVATIONS, DEFAULT_CONSTANTS, DERIVATIVES,
                                            ActivationConstants)
from scara_ident_ros.nn.errors import ModelFormatError
from scara_ident_ros.nn.fitting import ALGORITHMS, fit
from scara_ident_ros.nn.model_file import FORMAT_VERSION
from scara_ident_ros.nn.network import FeedForwardNet
from scara_ident_ros.nn.scaling import MinMaxScaling
from scara_ident_ros.nn.training import FitHistory

__all__ = [
    'ACTIVATIONS',
    'ALGORITHMS',
    'ActivationConstants',
    'DEFAULT_CONSTANTS',
    'DERIVATIVES',
    'FORMAT_VERSION',
    'FeedForwardNet',
    'FitHistory',
    'MinMaxScaling',
    'ModelFormatError',
    'fit',
]
