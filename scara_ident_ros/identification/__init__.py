"""Online identification core: joint-state samples in, a-priori effort predictions out.

Pure numpy, no rclpy: the ``identifier`` node converts messages and calls
:meth:`OnlineIdentifier.process`.
"""
from __future__ import annotations

from scara_ident_ros.identification.differentiator import METHODS, Differentiator

__all__ = ['Differentiator', 'METHODS']
