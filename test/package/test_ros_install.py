"""The ROS-install path as the README gives it: package.xml's keys resolve in rosdep, and
the README's commands work from the workspace (no rosdep or ros2 here: checked as text)."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# Every dependency key of package.xml, each checked to resolve: ROS 2 Jazzy packages (the
# distribution's package names), rosdep/base.yaml and rosdep/python.yaml keys. A key not
# here must be checked the same way first: python3-mcap-pip and
# python3-mcap-ros2-support-pip, which were here, are no rosdep keys.
ROSDEP_KEYS = {
    # ROS 2 Jazzy packages
    'rclpy', 'sensor_msgs', 'std_msgs', 'rosgraph_msgs', 'std_srvs', 'trajectory_msgs',
    'diagnostic_msgs', 'builtin_interfaces', 'rcl_interfaces', 'pinocchio',
    'example-robot-data',
    # rosdep/python.yaml
    'python3-numpy', 'python3-scipy', 'python3-yaml', 'python3-matplotlib',
    'python3-pytest', 'python3-rosbags-pip', 'mcap-ros2-support',
}
DEPENDS = ('depend', 'exec_depend', 'build_depend', 'test_depend', 'build_export_depend')


def readme_ros_section() -> str:
    text = (ROOT / 'README.md').read_text()
    start = text.index('## With a ROS 2 Jazzy install')
    return text[start:text.index('\n## ', start + 1)]


def test_every_package_xml_dependency_is_a_known_rosdep_key() -> None:
    root = ET.parse(ROOT / 'package.xml').getroot()
    keys = {element.text for tag in DEPENDS for element in root.iter(tag)}
    assert keys - ROSDEP_KEYS == set(), 'check these keys against rosdep first'
    assert {'python3-rosbags-pip', 'mcap-ros2-support', 'example-robot-data'} <= keys


def test_the_readme_installs_the_dependencies_before_building() -> None:
    section = readme_ros_section()
    rosdep = section.index('rosdep install --from-paths src -y --ignore-src')
    assert rosdep < section.index('colcon build')
    assert section.index('pip install') < section.index('colcon build')


def test_the_readme_parameter_file_is_the_installed_one() -> None:
    """``--params-file config/...`` only works from the source folder; the README's commands
    run from ~/ws."""
    section = readme_ros_section()
    files = re.findall(r'--params-file (\$\([^)]*\)\S*|\S+)', section)
    assert files, section
    for path in files:
        assert path.startswith('$(ros2 pkg prefix scara_ident_ros)/share/scara_ident_ros/')
        assert (ROOT / path.split('share/scara_ident_ros/', 1)[1].rstrip('`')).is_file()
