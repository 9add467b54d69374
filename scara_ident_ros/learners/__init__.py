"""Learners of joint efforts beyond the paper's networks, in pure numpy: kernel methods, the
linear baseline, and the hybrid (the robot's physical model plus a network of its residual:
:mod:`~scara_ident_ros.learners.hybrid_model`, imported by name, as it loads Pinocchio).

Nothing here imports rclpy. Each keeps the estimator contract of
:mod:`scara_ident_ros.estimator`.
"""
from __future__ import annotations

from scara_ident_ros.learners.exact_gp import ExactGP
from scara_ident_ros.learners.linear_features import LinearFeatures
from scara_ident_ros.learners.sparse_spectrum_gp import KIND, SparseSpectrumGP

__all__ = ['KIND', 'ExactGP', 'LinearFeatures', 'SparseSpectrumGP']
