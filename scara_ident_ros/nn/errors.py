"""Exceptions of the networks package."""
from __future__ import annotations

from scara_ident_ros.errors import ScaraIdentError

__all__ = ['ModelFormatError']


class ModelFormatError(ScaraIdentError, ValueError):
    """A file is not a network saved by `FeedForwardNet.save`, has another format version,
    or is corrupt. The message names the path and what is wrong with it."""
