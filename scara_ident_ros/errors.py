"""The package's base exception.

Every domain exception derives from :class:`ScaraIdentError` (``BagError``,
``ModelFormatError``, ``ParamError``, ``RecordingError``, ``ModelMismatch``, ``CliError``,
`ConfigError`), so ``scara-ident`` prints any of them as one line with exit status 2
from a single handler, and a node started by ``run_node`` does the same.
"""
from __future__ import annotations

__all__ = ['ConfigError', 'ScaraIdentError']


class ScaraIdentError(Exception):
    """An error the user can act on; the message is one line saying what and where."""


class ConfigError(ScaraIdentError):
    """A bad node parameter or configuration file: reported as one line, exit status 2."""
