"""Joint limits from a URDF: the shipped SCARA's equal its YAML's; bad URDFs say why."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.urdf_limits import UrdfError, parse_urdf, read_urdf
from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.identification.sample_check import joint_bounds

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / 'urdf' / 'scara.urdf'
YAML = ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml')
LIMITS = ('position_min', 'position_max', 'velocity_max', 'acceleration_max', 'effort_max')


def robot(*joints: str) -> str:
    """A URDF document with these ``<joint>`` elements (links omitted: not read)."""
    return '<robot name="r">' + ''.join(joints) + '</robot>'


def joint(name: str, kind: str = 'revolute', limit: str = 'lower="-1" upper="1" '
          'velocity="2" effort="3"') -> str:
    inner = f'<limit {limit}/>' if limit else ''
    return f'<joint name="{name}" type="{kind}">{inner}</joint>'


def test_the_shipped_urdf_has_the_yaml_limits_of_the_scara() -> None:
    urdf = read_urdf(URDF)
    assert urdf.names == YAML.joint_names and urdf.unlimited == {}
    for name in ('position_min', 'position_max', 'velocity_max', 'effort_max'):
        np.testing.assert_array_equal(getattr(urdf, name), YAML.array(name), err_msg=name)
    # the identifier's structure, with the YAML's accelerations: what robot_config gives
    limits = JointLimits.from_urdf(urdf, dict(zip(YAML.joint_names,
                                                  YAML.array('acceleration_max').tolist())))
    assert limits.names == YAML.joint_names
    for name in LIMITS:
        np.testing.assert_array_equal(getattr(limits, name), YAML.array(name), err_msg=name)
    bounds = joint_bounds(limits, 0.5)
    assert bounds is not None
    assert bounds.lo.shape == bounds.hi.shape == (3, 4)


def test_the_shipped_urdf_is_the_scara_of_the_yaml() -> None:
    """Link lengths, masses, inertias and the tool offset are the YAML's too."""
    root = ET.parse(URDF).getroot()

    def origin(joint_name: str) -> list[float]:
        element = root.find(f"joint[@name='{joint_name}']/origin")
        assert element is not None
        return [float(v) for v in element.get('xyz', '').split()]

    assert origin('joint2')[0] == YAML.l1 and origin('joint3')[0] == YAML.l2
    assert origin('tool0_joint')[2] == YAML.d4
    for link, mass, izz in (('link1', YAML.m1, YAML.izz1), ('link2', YAML.m2, YAML.izz2),
                            ('quill', YAML.m3, YAML.izz3), ('wrist', YAML.m4, YAML.izz4)):
        inertial = root.find(f"link[@name='{link}']/inertial")
        assert inertial is not None
        assert float(inertial.find('mass').get('value')) == mass  # type: ignore[union-attr]
        assert float(inertial.find('inertia').get('izz')) == izz  # type: ignore[union-attr]
    com = root.find("link[@name='link1']/inertial/origin")
    assert com is not None and float(com.get('xyz', '').split()[0]) == YAML.lc1


def test_limits_come_in_document_order_and_unlimited_joints_are_listed() -> None:
    urdf = parse_urdf(robot(joint('b', limit='lower="0" upper="0.2" velocity="1" '
                                  'effort="50"'),
                            joint('fixed', 'fixed', limit=''),
                            joint('spin', 'continuous', limit='velocity="1" effort="1"'),
                            joint('free', 'prismatic', limit=''),
                            joint('a', 'prismatic')))
    assert urdf.names == ('b', 'a')
    assert urdf.unlimited == {'spin': 'continuous', 'free': 'no <limit>'}
    np.testing.assert_array_equal(urdf.position_max, [0.2, 1.0])
    chosen = urdf.select(['a', 'b'])
    assert chosen.names == ('a', 'b') and chosen.effort_max.tolist() == [3.0, 50.0]


def test_joints_missing_in_the_urdf_are_reported() -> None:
    urdf = read_urdf(URDF)
    with pytest.raises(UrdfError, match=r"scara.urdf: no joint limits for shoulder \(not in "
                                        r"the URDF\), elbow \(not in the URDF\); the URDF has "
                                        r"limits for \['joint1', 'joint2', 'joint3', "
                                        r"'joint4'\]"):
        urdf.select(['joint1', 'shoulder', 'elbow'])
    spinning = parse_urdf(robot(joint('a'), joint('wrist', 'continuous')))
    with pytest.raises(UrdfError, match=r'wrist \(continuous\)'):
        spinning.select(['a', 'wrist'])
    # a joint without an acceleration limit is left out of the identifier's limits, and
    # reported if required
    assert JointLimits.from_urdf(urdf, {'joint2': 50.0}).names == ('joint2',)
    with pytest.raises(UrdfError, match=r"no acceleration limit for \['joint1'\]"):
        JointLimits.from_urdf(urdf, {'joint2': 50.0}, required=['joint2', 'joint1'])
    with pytest.raises(UrdfError, match=r'no joint limits for shoulder'):
        JointLimits.from_urdf(urdf, {'shoulder': 50.0}, required=['shoulder'])


@pytest.mark.parametrize(('text', 'fragment'), [
    ('', 'robot_description: empty URDF'),
    ('<robot name="r"><joint name="a" type="revolute">', 'not valid XML: no element found: '
                                                         'line 1, column 48'),
    ('<?xml version="1.0"?>\n<sdf/>', 'the root element is <sdf>, not <robot>'),
    (robot('<joint type="revolute"/>'), 'a <joint> without a name or type'),
    (robot(joint('a'), joint('a')), "joint 'a' is defined twice"),
    (robot(joint('a', limit='lower="-1" upper="1" velocity="2"')),
     "joint 'a': <limit> has no 'effort'"),
    (robot(joint('a', limit='upper="1" velocity="2" effort="3"')),
     "joint 'a': <limit> has no 'lower'"),
    (robot(joint('a', limit='lower="-1" upper="one" velocity="2" effort="3"')),
     '<limit upper="one"> is not a number'),
    (robot(joint('a', limit='lower="-1" upper="nan" velocity="2" effort="3"')),
     '<limit upper="nan"> is not finite'),
    (robot(joint('a', limit='lower="1" upper="1" velocity="2" effort="3"')),
     'lower limit 1 is not below upper 1'),
    (robot(joint('a', limit='lower="-1" upper="1" velocity="0" effort="3"')),
     'velocity and effort limits must be > 0, got 0 and 3'),
])
def test_a_bad_urdf_says_what_and_where(text: str, fragment: str) -> None:
    with pytest.raises(UrdfError, match=fragment):
        parse_urdf(text)
    with pytest.raises(UrdfError) as info:
        parse_urdf(text, source='my.urdf')
    assert str(info.value).startswith('my.urdf: ') and '\n' not in str(info.value)


def test_an_unreadable_file_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(UrdfError, match=r'missing.urdf: cannot read the URDF'):
        read_urdf(tmp_path / 'missing.urdf')
    bad = tmp_path / 'bad.urdf'
    bad.write_text('<robot><joint name="a" type="revolute"><limit lower="0"/></joint></robot>')
    with pytest.raises(UrdfError, match=r"bad.urdf: joint 'a': <limit> has no 'upper'"):
        read_urdf(bad)
