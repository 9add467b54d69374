"""The venv's interpreter and console scripts run on the venv's own ROS libraries, whatever
the calling shell holds (``scara_ident_ros/nodes/rosenv.py``).

Two poisoned callers, as seen in issue 26: a process of another venv with ROS wheels (the
bootstrapper's mark set, ``LD_LIBRARY_PATH`` on that venv's libraries, which lack
trajectory_msgs) and a shell with a sourced ROS install (its library directory first in
``LD_LIBRARY_PATH``, its ``rclpy`` for another Python in ``PYTHONPATH``, its prefix in
``AMENT_PREFIX_PATH``). Both are faked in ``tmp_path``: what breaks the interpreter is what
their paths hold, and the fakes hold exactly that.
"""
from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from scara_ident_ros.nodes.rosenv import (BOOTSTRAP_MARK, PTH_NAME, own_library_dirs,
                                          own_ros_environment)

pytestmark = pytest.mark.ros

PREFIX = Path(sys.prefix)
SITE = Path(sysconfig.get_paths()['purelib'])
# rclpy imported from this venv, and a message of a package the other venv lacks serialized
# (its type support is a library found through LD_LIBRARY_PATH)
CHECK = ('import os, rclpy, rclpy.serialization, trajectory_msgs.msg as m; '
         'n = len(rclpy.serialization.serialize_message(m.JointTrajectory())); '
         'print(rclpy.__file__, n, os.environ.get("PYTHONPATH", ""), sep="\\n")')


def fake_other_venv(tmp_path: Path) -> dict[str, str]:
    """The environment a process of another ROS-wheels venv passes on."""
    libs = tmp_path / 'othervenv' / 'lib' / 'python3.11' / 'site-packages' / 'ros_rcl.libs'
    libs.mkdir(parents=True)
    lib = tmp_path / 'othervenv' / 'lib'
    (lib / 'librcutils.so').write_bytes(b'')  # not loadable: must never be searched
    return {BOOTSTRAP_MARK: '1', 'LD_LIBRARY_PATH': f'{lib}{os.pathsep}{libs}'}


def fake_sourced_ros(tmp_path: Path) -> dict[str, str]:
    """The environment of a shell that sourced /opt/ros/jazzy/setup.bash."""
    ros = tmp_path / 'opt' / 'ros' / 'jazzy'
    python = ros / 'lib' / 'python3.12' / 'site-packages'
    (python / 'rclpy').mkdir(parents=True)
    (python / 'rclpy' / '__init__.py').write_text(
        "raise ImportError('the sourced install\\'s rclpy, built for Python 3.12')\n")
    for name in ('librcutils.so', 'libtrajectory_msgs__rosidl_generator_py.so'):
        (ros / 'lib' / name).write_bytes(b'')  # found first, it would fail to load
    return {'LD_LIBRARY_PATH': str(ros / 'lib'), 'PYTHONPATH': str(python),
            'AMENT_PREFIX_PATH': str(ros), 'ROS_DISTRO': 'jazzy'}


def poisoned(tmp_path: Path, which: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if k not in (BOOTSTRAP_MARK, 'LD_LIBRARY_PATH', 'PYTHONPATH', 'AMENT_PREFIX_PATH')}
    env.update(fake_other_venv(tmp_path) if which == 'other venv' else fake_sourced_ros(tmp_path))
    return env


def test_the_venv_installs_the_environment_guard() -> None:
    assert own_library_dirs(PREFIX, SITE), 'this venv has no ROS wheels'
    assert (SITE / PTH_NAME).is_file(), f'make venv writes {SITE / PTH_NAME}'
    assert sorted([PTH_NAME, 'ros_wheels_bootstrapper.pth'])[0] == PTH_NAME  # runs first


@pytest.mark.parametrize('which', ['other venv', 'sourced ROS'])
def test_the_interpreter_imports_its_own_ros_libraries(tmp_path: Path, which: str) -> None:
    env = poisoned(tmp_path, which)
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [env.get('PYTHONPATH'), str(tmp_path)]))
    result = subprocess.run([sys.executable, '-c', CHECK], env=env, capture_output=True,
                            text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    module, size, pythonpath = result.stdout.splitlines()
    assert Path(module).is_relative_to(SITE) and int(size) > 0
    assert pythonpath == str(tmp_path)  # a PYTHONPATH entry without rclpy is kept


@pytest.mark.parametrize('which', ['other venv', 'sourced ROS'])
def test_a_console_script_starts_in_a_poisoned_shell(tmp_path: Path, which: str) -> None:
    exe = Path(sys.executable).with_name('excitation')  # imports rclpy and trajectory_msgs
    result = subprocess.run([str(exe), '--help'], env=poisoned(tmp_path, which),
                            capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    assert 'excitation' in result.stdout


def test_own_ros_environment_puts_own_libraries_first_and_drops_other_ros(
        tmp_path: Path) -> None:
    prefix, site = tmp_path / 'venv', tmp_path / 'venv' / 'site-packages'
    (site / 'ros_rcl.libs').mkdir(parents=True)
    (prefix / 'lib').mkdir()
    (prefix / 'lib' / 'librcutils.so').write_bytes(b'')
    other = fake_sourced_ros(tmp_path / 'a')
    other_venv = fake_other_venv(tmp_path / 'b')
    plain = tmp_path / 'cuda'
    plain.mkdir()
    workspace = tmp_path / 'ws' / 'install' / 'scara_ident_ros'  # python only: no ROS libs
    environ = {
        BOOTSTRAP_MARK: '1', 'HOME': '/home/u',
        'LD_LIBRARY_PATH': os.pathsep.join([other['LD_LIBRARY_PATH'], str(plain),
                                            other_venv['LD_LIBRARY_PATH']]),
        'PYTHONPATH': os.pathsep.join([other['PYTHONPATH'], str(tmp_path)]),
        'AMENT_PREFIX_PATH': os.pathsep.join([str(workspace), other['AMENT_PREFIX_PATH']])}
    env = own_ros_environment(environ, prefix, site)
    assert env['LD_LIBRARY_PATH'].split(os.pathsep) == [
        str(prefix / 'lib'), str((site / 'ros_rcl.libs').resolve()), str(plain)]
    assert env['PYTHONPATH'] == str(tmp_path)
    assert env['AMENT_PREFIX_PATH'] == str(workspace)
    assert env[BOOTSTRAP_MARK] == '1' and env['HOME'] == '/home/u'
    assert own_ros_environment(env, prefix, site) == env  # stable: one restart, no loop
    # only ROS paths: the variables go; no ROS wheels in the venv: nothing changes
    env = own_ros_environment({**environ, 'PYTHONPATH': other['PYTHONPATH'],
                               'AMENT_PREFIX_PATH': other['AMENT_PREFIX_PATH']}, prefix, site)
    assert 'PYTHONPATH' not in env and 'AMENT_PREFIX_PATH' not in env
    assert own_ros_environment(environ, tmp_path / 'plain', tmp_path / 'plain') == environ
