"""Where the arms of example-robot-data are found: the PyPI package, or a ROS install."""
from __future__ import annotations

from importlib import metadata
from pathlib import Path

import pytest

from scara_ident_ros.sim import example_robots
from scara_ident_ros.sim.example_robots import ExampleRobotError, example_robot, robot_roots


def _no_pypi_package(monkeypatch: pytest.MonkeyPatch) -> None:
    def missing(name: str) -> metadata.Distribution:
        raise metadata.PackageNotFoundError(name)
    monkeypatch.setattr(example_robots.metadata, 'distribution', missing)


def test_a_ros_install_of_the_descriptions_is_found_through_ament_prefix_path(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _no_pypi_package(monkeypatch)
    empty, prefix = tmp_path / 'ws' / 'install', tmp_path / 'opt' / 'ros' / 'jazzy'
    urdf = prefix / 'share/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf'
    urdf.parent.mkdir(parents=True)
    urdf.write_text('<robot name="ur5"/>')
    empty.mkdir(parents=True)
    monkeypatch.setenv('AMENT_PREFIX_PATH', f'{empty}:{prefix}')
    assert robot_roots() == [prefix / 'share/example-robot-data/robots']
    assert example_robot('ur5').urdf == str(urdf)
    with pytest.raises(ExampleRobotError, match='panda.urdf is missing'):
        example_robot('panda')


def test_without_either_install_the_error_names_both_packages(
        monkeypatch: pytest.MonkeyPatch) -> None:
    _no_pypi_package(monkeypatch)
    monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)
    with pytest.raises(ExampleRobotError, match='pip install example-robot-data.*'
                                                'ros-jazzy-example-robot-data'):
        example_robot('ur5')


def test_the_pypi_package_comes_first() -> None:
    roots = robot_roots()
    assert roots and 'cmeel.prefix' in str(roots[0])
    assert Path(example_robot('panda').urdf).is_file()
