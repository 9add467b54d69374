"""The software versions a report records, so that its figures can be reproduced."""
from __future__ import annotations

import platform
import subprocess
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

__all__ = ['software_versions']


def software_versions() -> dict[str, str]:
    """Python, numpy, scipy, this package and its git commit when run from a checkout."""
    import scipy

    versions = {'python': platform.python_version(), 'numpy': np.__version__,
                'scipy': scipy.__version__}
    try:
        versions['scara_ident_ros'] = version('scara_ident_ros')
    except PackageNotFoundError:  # run from the source tree
        versions['scara_ident_ros'] = 'source tree'
    try:
        commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                                text=True, timeout=5, cwd=Path(__file__).parent,
                                check=False).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ''
    if commit:
        versions['git'] = commit
    return versions
