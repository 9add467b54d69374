"""``colcon build`` installs every executable where ``ros2 run`` looks for it.

``ros2 run scara_ident_ros NAME`` executes ``<prefix>/lib/scara_ident_ros/NAME``
in an environment sourced from ``install/setup.sh``; this test does exactly that
without the ros2 CLI.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'scara_ident_ros'
NODES = ('scara_sim', 'robot_sim', 'identifier', 'recorder', 'player', 'excitation')
EXECUTABLES = (*NODES, 'scara-ident')
COPY_IGNORE = shutil.ignore_patterns('.venv', '.git', 'build', 'install', 'log', 'out',
                                     '__pycache__', '*.egg-info', '.pytest_cache')


@pytest.fixture(scope='module')
def install(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Build the package with colcon in a fresh workspace; return its install/ dir."""
    workspace = tmp_path_factory.mktemp('ws')
    shutil.copytree(REPO, workspace / 'src' / PACKAGE, ignore=COPY_IGNORE)
    colcon = Path(sys.executable).with_name('colcon')
    result = subprocess.run(
        [str(colcon), 'build', '--base-paths', 'src'], cwd=workspace,
        capture_output=True, text=True, timeout=300, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    return workspace / 'install'


def sourced_env(install: Path) -> dict[str, str]:
    """Return the environment ``. install/setup.sh`` gives."""
    out = subprocess.run(['bash', '-c', f'. {install}/setup.sh && env -0'],
                         capture_output=True, check=True, timeout=60).stdout
    env = dict(item.split('=', 1) for item in out.decode().split('\0') if '=' in item)
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    return env


def test_every_executable_is_installed_where_ros2_run_looks(install: Path) -> None:
    lib = install / PACKAGE / 'lib' / PACKAGE
    missing = [name for name in EXECUTABLES if not os.access(lib / name, os.X_OK)]
    assert not missing, f'not executable in {lib}: {missing}'
    share = install / PACKAGE / 'share' / PACKAGE
    assert (share / 'package.xml').is_file()
    assert sorted(p.name for p in (share / 'config').glob('*.yaml'))
    assert (share / 'config' / 'fastdds.xml').is_file()  # the writers' heartbeat
    assert (share / 'launch' / 'identification.launch.py').is_file()
    assert (share / 'urdf' / 'scara.urdf').is_file()
    marker = install / PACKAGE / 'share' / 'ament_index' / 'resource_index' / 'packages'
    assert (marker / PACKAGE).is_file()


def test_scara_ident_cli_starts_from_the_install(install: Path) -> None:
    exe = install / PACKAGE / 'lib' / PACKAGE / 'scara-ident'
    result = subprocess.run([str(exe), '--help'], env=sourced_env(install),
                            capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 0, result.stderr
    for command in ('run', 'play', 'train', 'evaluate', 'tables', 'compare', 'recover',
                    'export'):
        assert command in result.stdout


@pytest.mark.parametrize('name', NODES)
def test_node_starts_from_the_install_and_stops_on_sigint(
        install: Path, name: str, tmp_path: Path) -> None:
    exe = install / PACKAGE / 'lib' / PACKAGE / name
    ros_args = {
        'recorder': ['-p', f'output:={tmp_path / "bag"}'],
        'player': ['-p', f'bag:={REPO / "bags" / "demo_run"}', '-p', 'loop:=true'],
        'robot_sim': ['-p', 'robot:=ur5'],
        # waits for /joint_states and a controller, which never come here
        'excitation': ['-p', f'urdf_file:={REPO / "urdf" / "scara.urdf"}',
                       '-p', 'wait_timeout:=60.0'],
    }.get(name, [])
    proc = subprocess.Popen([str(exe), '--ros-args', *ros_args], env=sourced_env(install),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(3.0)
        assert proc.poll() is None, f'{name} exited early: {proc.communicate()}'
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)  # s: the hang guard of rostest.STOP_TIMEOUT
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert 'Traceback' not in err
