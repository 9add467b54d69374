"""The process environment of the project's ROS processes: its own ROS libraries, local DDS.

:func:`ensure_local_dds` sets what every process of the package joins DDS with: discovery on
this machine, and Fast DDS's profile ``config/fastdds.xml`` (20 ms heartbeats).

In the project's venv, ROS comes as PyPI wheels whose shared libraries live in the venv
(``<prefix>/lib`` and ``site-packages/ros_*.libs``). The wheels' bootstrapper
(``ros_wheels_bootstrapper.pth``) re-executes every interpreter once with those directories
in ``LD_LIBRARY_PATH`` and marks the environment ``_ROS_WHEELS_BOOTSTRAP_COMPLETE=1``. It
trusts that mark and keeps whatever else the caller's paths hold, in an order left to a
``set``: started from another venv with ROS wheels (which set the mark and its own
directories), the interpreter ran on that venv's libraries; from a shell with a sourced ROS
install (``/opt/ros/jazzy/lib``, its ``PYTHONPATH`` and ``AMENT_PREFIX_PATH``) it mixed the
two sets of libraries and imported the install's ``rclpy``, built for another Python.

:func:`use_own_ros_libraries` runs first (``make venv`` installs :data:`PTH_NAME`, sorted
before the bootstrapper's ``.pth``, into the venv) and re-executes the interpreter on
:func:`own_ros_environment`: this venv's library directories first, no other ROS library
directory, no ``PYTHONPATH`` entry that holds another ``rclpy``, no ``AMENT_PREFIX_PATH``
entry of another ROS install. Outside such a venv (a sourced ROS install running the
package built by colcon) it does nothing.
"""
from __future__ import annotations

import os
import sys
import sysconfig
from collections.abc import Mapping
from pathlib import Path

__all__ = ['BOOTSTRAP_MARK', 'PTH_NAME', 'ensure_local_dds', 'install_pth',
           'own_library_dirs', 'own_ros_environment', 'use_own_ros_libraries']

BOOTSTRAP_MARK = '_ROS_WHEELS_BOOTSTRAP_COMPLETE'  # the ROS wheels bootstrapper's guard
# site processes .pth files in sorted order: after setuptools' __editable__ finder (which
# makes this package importable), before ros_wheels_bootstrapper.pth
PTH_NAME = 'ros_env_scara_ident_ros.pth'
PTH_LINE = ('import scara_ident_ros.nodes.rosenv as _rosenv; '
            '_rosenv.use_own_ros_libraries()\n')
PYTHON_PACKAGE_OF_ROS = 'rclpy'  # a PYTHONPATH entry holding it would shadow the venv's

PROFILE_FILE = 'fastdds.xml'  # in config/: the writers' 20 ms heartbeat
PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')
FAST_DDS = ('', 'rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp')  # RMW_IMPLEMENTATION values


def ensure_local_dds() -> None:
    """Set ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` unless the user chose a range, and
    with Fast DDS the profile :data:`PROFILE_FILE` unless the user gave one.

    Must run before ``rclpy.init``: without it Fast DDS multicasts discovery
    traffic off the machine, and a reliable writer repairs a sample the transport dropped
    only at its next heartbeat, 3 s later by default (``config/fastdds.xml``: 20 ms); the
    reader's later samples wait for it. Set in a process, both hold for its children.
    """
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    if any(os.environ.get(name) for name in PROFILE_VARIABLES):
        return
    if os.environ.get('RMW_IMPLEMENTATION', '') not in FAST_DDS:
        return
    from scara_ident_ros.resources import config_path

    try:
        os.environ[PROFILE_VARIABLES[0]] = str(config_path(PROFILE_FILE))
    except FileNotFoundError:  # an install without it: Fast DDS's 3 s heartbeat
        pass


def own_library_dirs(prefix: Path, site_packages: Path) -> list[str]:
    """The ROS wheels' library directories of the environment at ``prefix``.

    Returns
    -------
    list of str
        ``prefix/lib`` if it holds ROS libraries, then ``site_packages/ros_*.libs`` sorted;
        empty when the environment has no ROS wheels.
    """
    dirs = [str(prefix / 'lib')] if (prefix / 'lib' / 'librcutils.so').is_file() else []
    if site_packages.is_dir():
        dirs += sorted(str(p.resolve()) for p in site_packages.glob('ros_*.libs') if p.is_dir())
    return dirs


def _is_ros_library_dir(path: str) -> bool:
    """A directory of ROS 2 libraries: another venv's wheels, a ROS install, a workspace."""
    p = Path(path)
    if p.name.startswith('ros_') and p.name.endswith('.libs'):
        return True
    try:
        return (p / 'librcutils.so').exists() or any(p.glob('lib*__rosidl_*.so'))
    except OSError:
        return False


def _split(value: str | None) -> list[str]:
    return [part for part in (value or '').split(os.pathsep) if part]


def own_ros_environment(environ: Mapping[str, str], prefix: Path,
                        site_packages: Path) -> dict[str, str]:
    """``environ`` as an interpreter of the venv at ``prefix`` must run with.

    Parameters
    ----------
    environ : Mapping[str, str]
        The caller's environment.
    prefix : Path
        The interpreter's ``sys.prefix``.
    site_packages : Path
        Its ``site-packages`` (where the ROS wheels put ``ros_*.libs``).

    Returns
    -------
    dict[str, str]
        A copy of ``environ``; if the venv has ROS wheels: ``LD_LIBRARY_PATH`` starts with
        :func:`own_library_dirs` and keeps the caller's other entries except ROS library
        directories, ``PYTHONPATH`` loses the entries that hold an ``rclpy``,
        ``AMENT_PREFIX_PATH`` the prefixes with ROS libraries, and the bootstrapper's mark
        is set. The same environment given back returns unchanged.
    """
    env = dict(environ)
    own = own_library_dirs(prefix, site_packages)
    if not own:
        return env
    kept = [p for p in _split(env.get('LD_LIBRARY_PATH'))
            if p not in own and not _is_ros_library_dir(p)]
    env['LD_LIBRARY_PATH'] = os.pathsep.join(own + kept)
    for name, foreign in (
            ('PYTHONPATH', lambda p: (Path(p) / PYTHON_PACKAGE_OF_ROS).is_dir()),
            ('AMENT_PREFIX_PATH', lambda p: _is_ros_library_dir(str(Path(p) / 'lib')))):
        if name in env:
            parts = [p for p in _split(env[name]) if not foreign(p)]
            if parts:
                env[name] = os.pathsep.join(parts)
            else:
                del env[name]
    env[BOOTSTRAP_MARK] = '1'
    return env


def use_own_ros_libraries() -> None:
    """Re-execute this interpreter on :func:`own_ros_environment` unless it runs on it.

    The dynamic loader reads ``LD_LIBRARY_PATH`` once, when the process starts, so the
    interpreter is started again (``os.execve``, same arguments) rather than the variable
    changed. Runs from :data:`PTH_NAME` before any module is imported.
    """
    site = Path(sysconfig.get_paths()['purelib'])
    env = own_ros_environment(os.environ, Path(sys.prefix), site)
    if env == dict(os.environ):
        return
    try:
        os.execve(sys.executable, sys.orig_argv, env)
    except OSError as error:  # go on as the bootstrapper would have
        sys.stderr.write(f'scara_ident_ros: could not restart {sys.executable} on its own '
                         f'ROS libraries: {error}\n')


def install_pth() -> Path:
    """Write :data:`PTH_NAME` into this interpreter's ``site-packages``; return its path."""
    path = Path(sysconfig.get_paths()['purelib']) / PTH_NAME
    path.write_text(PTH_LINE)
    return path
