"""Arms of the ``example-robot-data`` package, by name: where their URDF is installed.

``example-robot-data`` (PyPI, a cmeel wheel; the Gepetto team's robot descriptions) installs
its URDFs and meshes under ``<site-packages>/cmeel.prefix/share/example-robot-data/robots``;
on a ROS install, ``ros-jazzy-example-robot-data`` (what ``rosdep`` installs) puts them under
``<prefix>/share/example-robot-data/robots`` of a prefix in ``AMENT_PREFIX_PATH``. The PyPI
package is looked at first, then each ament prefix in order.
It is installed with the tests, benchmarks and demos (``requirements.txt``), not copied into
this repository. Each entry names the URDF and, for a robot with more joints than its arm
(a gripper), the joints to simulate; the others are locked (see
:meth:`~scara_ident_ros.sim.pinocchio_robot.PinocchioRobot.from_urdf`).
"""
from __future__ import annotations

from dataclasses import dataclass
import os
from importlib import metadata
from pathlib import Path

from scara_ident_ros.errors import ScaraIdentError

__all__ = ['EXAMPLE_ROBOTS', 'ExampleRobot', 'ExampleRobotError', 'example_robot',
           'DISTRIBUTION', 'robot_roots']

#: The PyPI distribution that holds the descriptions.
DISTRIBUTION = 'example-robot-data'
_SHARE_DIR = 'share/example-robot-data/robots'
_ROBOTS_DIR = f'cmeel.prefix/{_SHARE_DIR}'


class ExampleRobotError(ScaraIdentError, ValueError):
    """An unknown robot name, or ``example-robot-data`` not installed; says what to do."""


@dataclass(frozen=True)
class ExampleRobot:
    """One arm of ``example-robot-data``.

    Attributes
    ----------
    urdf : str
        The URDF, relative to the package's ``robots`` folder (absolute once resolved by
        :func:`example_robot`).
    joints : tuple of str
        The joints to simulate, in order; empty: every revolute and prismatic joint.
    """

    urdf: str
    joints: tuple[str, ...] = ()


#: The arms whose joints are all revolute with limits (Kinova's continuous joints and the
#: legged robots are left out).
EXAMPLE_ROBOTS: dict[str, ExampleRobot] = {
    'ur3': ExampleRobot('ur_description/urdf/ur3_robot.urdf'),
    'ur5': ExampleRobot('ur_description/urdf/ur5_robot.urdf'),
    'ur10': ExampleRobot('ur_description/urdf/ur10_robot.urdf'),
    # the arm's 7 joints; the two finger joints are locked half open
    'panda': ExampleRobot('panda_description/urdf/panda.urdf',
                          tuple(f'panda_joint{i}' for i in range(1, 8))),
    'xarm7': ExampleRobot('xarm_description/urdf/xarm7.urdf'),
    # the arm's 6 joints; the gripper joint is locked
    'z1': ExampleRobot('z1_description/urdf/z1.urdf',
                       tuple(f'joint{i}' for i in range(1, 7))),
}


def example_robot(name: str) -> ExampleRobot:
    """The arm ``name`` with the absolute path of its installed URDF.

    Raises
    ------
    ExampleRobotError
        For a name not in :data:`EXAMPLE_ROBOTS` (the message lists them), or when
        ``example-robot-data`` is not installed or lacks the file.
    """
    if name not in EXAMPLE_ROBOTS:
        raise ExampleRobotError(f'unknown robot {name!r}; known robots are '
                                f'{", ".join(sorted(EXAMPLE_ROBOTS))}')
    robot = EXAMPLE_ROBOTS[name]
    roots = robot_roots()
    if not roots:
        raise ExampleRobotError(f'robot {name!r} needs the {DISTRIBUTION} package: '
                                f'pip install {DISTRIBUTION} (or, on a ROS install, '
                                f'ros-jazzy-example-robot-data)')
    path = next((root / robot.urdf for root in roots if (root / robot.urdf).is_file()),
                roots[0] / robot.urdf)
    if not path.is_file():
        raise ExampleRobotError(f'robot {name!r}: {path} is missing; is {DISTRIBUTION} '
                                f'installed completely?')
    return ExampleRobot(str(path), robot.joints)


def robot_roots() -> list[Path]:
    """The installed ``robots`` folders of ``example-robot-data``: the PyPI package's, then
    ``<prefix>/share/example-robot-data/robots`` of each ``AMENT_PREFIX_PATH`` entry that has
    one (a ROS install); empty if neither is installed."""
    roots = []
    try:
        roots.append(Path(str(metadata.distribution(DISTRIBUTION).locate_file(_ROBOTS_DIR))))
    except metadata.PackageNotFoundError:
        pass
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            roots.append(Path(prefix) / _SHARE_DIR)
    return [root for root in roots if root.is_dir()]
