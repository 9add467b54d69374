"""Where the package's installed data files (``config/``, ``launch/``) live.

The same lookup serves a ``colcon build`` install (ament index), a pip install
(``<prefix>/share/scara_ident_ros``) and a source checkout.
"""
from __future__ import annotations

import sys
from functools import cache
from pathlib import Path

__all__ = ['PACKAGE', 'share_dir', 'config_path']

PACKAGE = 'scara_ident_ros'


@cache
def share_dir() -> Path:
    """Return the package's share directory (the one holding ``config/``)."""
    candidates: list[Path] = []
    try:
        from ament_index_python.packages import get_package_share_directory
        candidates.append(Path(get_package_share_directory(PACKAGE)))
    except (ImportError, LookupError, OSError, ValueError):
        pass  # no ament index (pip install or source checkout), or not listed in it
    candidates.append(Path(sys.prefix) / 'share' / PACKAGE)
    candidates.append(Path(__file__).resolve().parent.parent)  # source checkout
    for candidate in candidates:
        if (candidate / 'config').is_dir():
            return candidate
    raise FileNotFoundError(f'no {PACKAGE} share directory with config/ among '
                            f'{", ".join(map(str, candidates))}')


def config_path(name: str) -> Path:
    """Return the path of the installed ``config/<name>`` file."""
    path = share_dir() / 'config' / name
    if not path.is_file():
        raise FileNotFoundError(f'{path} does not exist')
    return path
