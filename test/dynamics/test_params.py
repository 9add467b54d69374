"""Tests of ScaraParams: defaults, validation, YAML and dict round trips."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from scara_ident_ros.dynamics.params import VECTOR_FIELDS, ParamError, ScaraParams

CONFIG = Path(__file__).resolve().parents[2] / 'config' / 'scara.yaml'


def test_yaml_matches_dataclass_defaults() -> None:
    data = yaml.safe_load(CONFIG.read_text(encoding='utf-8'))
    names = [f.name for f in dataclasses.fields(ScaraParams)]
    assert list(data) == names
    assert ScaraParams.from_yaml(CONFIG) == ScaraParams()
    assert ScaraParams().to_dict() == data


def test_defaults_are_a_plausible_industrial_scara() -> None:
    p = ScaraParams()
    assert 0.3 <= p.l1 <= 0.5 and 0.2 <= p.l2 <= 0.35
    assert 0.15 <= p.position_max[2] - p.position_min[2] <= 0.3   # quill stroke, m
    assert p.joint_names == ('joint1', 'joint2', 'joint3', 'joint4')
    # the quill's weight must be far inside joint 3's force limit
    assert (p.m3 + p.m4) * p.gravity < 0.5 * p.effort_max[2]


def test_vectors_are_float_tuples_and_hashable() -> None:
    p = ScaraParams.from_dict({'viscous': [1, 2, 3, 4], 'm1': 3})
    assert p.viscous == (1.0, 2.0, 3.0, 4.0)
    assert all(isinstance(v, float) for v in p.viscous)
    assert isinstance(p.m1, float)
    hash(p)
    np.testing.assert_array_equal(p.array('viscous'), [1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(p.position_centre, [0.0, 0.0, 0.1, 0.0])
    for name in VECTOR_FIELDS:
        assert p.array(name).shape == (4,)


def test_dict_round_trip() -> None:
    p = ScaraParams(m4=4.5, joint_names=('a', 'b', 'c', 'd'))
    assert ScaraParams.from_dict(p.to_dict()) == p


def test_yaml_round_trip(tmp_path: Path) -> None:
    p = ScaraParams(l1=0.5, coulomb=(1.0, 1.0, 2.0, 0.1))
    path = tmp_path / 'robot.yaml'
    path.write_text(yaml.safe_dump(p.to_dict()), encoding='utf-8')
    assert ScaraParams.from_yaml(path) == p


def test_a_robot_file_must_name_every_parameter(tmp_path: Path) -> None:
    full = yaml.safe_load(CONFIG.read_text(encoding='utf-8'))
    del full['izz3'], full['coulomb']
    path = tmp_path / 'partial.yaml'
    path.write_text(yaml.safe_dump(full), encoding='utf-8')
    with pytest.raises(ParamError, match=r'partial.yaml: missing parameter\(s\) izz3, coulomb;'):
        ScaraParams.from_yaml(path)
    path.write_text('', encoding='utf-8')
    with pytest.raises(ParamError, match='missing parameter'):
        ScaraParams.from_yaml(path)


def test_missing_keys_take_defaults_in_from_dict() -> None:
    assert ScaraParams.from_dict({'m4': 2.0}) == dataclasses.replace(ScaraParams(), m4=2.0)


@pytest.mark.parametrize(('changes', 'fragment'), [
    ({'m2': -1.0}, 'm2 must be > 0, got -1.0'),
    ({'l1': 0.0}, 'l1 must be > 0'),
    ({'izz3': -0.1}, 'izz3 must be > 0'),
    ({'lc1': 0.9}, 'lc1 must be <= l1'),
    ({'lc2': -0.1}, 'lc2 must be >= 0'),
    ({'gravity': math.nan}, 'gravity must be finite'),
    ({'coulomb_eps': 0.0}, 'coulomb_eps must be > 0'),
    ({'m1': 'heavy'}, 'm1 must be a number'),
    ({'m1': True}, 'm1 must be a number'),
    ({'viscous': (1.0, 2.0, 3.0)}, 'viscous must have 4 values'),
    ({'viscous': 1.0}, 'viscous must be a sequence of 4 numbers'),
    ({'coulomb': (1.0, -2.0, 3.0, 4.0)}, 'coulomb[1] must be >= 0'),
    ({'position_max': (1.0, 1.0, math.inf, 1.0)}, 'position_max[2] must be finite'),
    ({'position_min': (-1.0, 3.0, 0.0, -1.0)}, 'position_min[1] must be < position_max[1]'),
    ({'velocity_max': (1.0, 0.0, 1.0, 1.0)}, 'velocity_max[1] must be > 0'),
    ({'effort_max': (1.0, 1.0, 1.0, -5.0)}, 'effort_max[3] must be > 0'),
    ({'joint_names': ('a', 'b', 'c')}, 'joint_names must be a sequence of 4'),
    ({'joint_names': ('a', 'b', 'a', 'd')}, 'joint_names must be unique'),
    ({'joint_names': ('a', '', 'c', 'd')}, 'joint_names must be non-empty'),
])
def test_invalid_values_name_the_field(changes: dict, fragment: str) -> None:
    with pytest.raises(ParamError, match=fragment.replace('[', r'\[').replace(']', r'\]')):
        ScaraParams(**changes)


def test_param_error_is_a_value_error() -> None:
    assert issubclass(ParamError, ValueError)


def test_unknown_keys_are_named() -> None:
    with pytest.raises(ParamError, match='unknown parameter.*mass5.*zeta'):
        ScaraParams.from_dict({'zeta': 1, 'mass5': 2, 'm1': 3.0})


def test_from_dict_rejects_non_mapping() -> None:
    with pytest.raises(ParamError, match='mapping'):
        ScaraParams.from_dict([1, 2])  # type: ignore[arg-type]


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    path = tmp_path / 'absent.yaml'
    with pytest.raises(ParamError, match='absent.yaml'):
        ScaraParams.from_yaml(path)


@pytest.mark.parametrize('text', ['- 1\n- 2\n', '42\n', 'just a string\n'])
def test_non_mapping_yaml_names_the_path(tmp_path: Path, text: str) -> None:
    path = tmp_path / 'bad.yaml'
    path.write_text(text, encoding='utf-8')
    with pytest.raises(ParamError, match=r'bad\.yaml.*mapping'):
        ScaraParams.from_yaml(path)


def test_invalid_value_in_yaml_names_path_and_field(tmp_path: Path) -> None:
    path = tmp_path / 'robot.yaml'
    path.write_text('m3: -2.0\nfoo: 1\n', encoding='utf-8')
    with pytest.raises(ParamError, match=r'robot\.yaml.*foo'):
        ScaraParams.from_yaml(path)
    full = yaml.safe_load(CONFIG.read_text(encoding='utf-8'))
    path.write_text(yaml.safe_dump({**full, 'm3': -2.0}), encoding='utf-8')
    with pytest.raises(ParamError, match=r'robot\.yaml: m3 must be > 0, got -2.0'):
        ScaraParams.from_yaml(path)


def test_perturbed_changes_inertial_and_friction_only() -> None:
    p = ScaraParams()
    q = p.perturbed(0.2, seed=3)
    assert q != p and q == p.perturbed(0.2, seed=3)
    assert q.l1 == p.l1 and q.effort_max == p.effort_max and q.gravity == p.gravity
    for name in ('m1', 'm2', 'm3', 'm4', 'izz1', 'izz4'):
        assert abs(getattr(q, name) / getattr(p, name) - 1.0) <= 0.2
    assert p.perturbed(0.0, seed=1) == p
    with pytest.raises(ParamError, match='relative must be < 1'):
        p.perturbed(1.5, seed=0)
