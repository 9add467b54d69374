"""IdentifierSettings: one field per parameter of the identifier's table, its defaults the
table's, names and values checked at the boundary (defaults, of, from_yaml, replace)."""
from __future__ import annotations

from pathlib import Path

import pytest

from scara_ident_ros.identification.identifier_settings import (IdentifierSettings,
                                                                SettingsError)
from scara_ident_ros.identification.parameters import IDENTIFIER_PARAMETERS
from scara_ident_ros.resources import config_path


def test_the_defaults_are_the_tables_for_every_field() -> None:
    settings = IdentifierSettings.defaults()
    values = settings.as_dict()
    assert list(values) == [spec.name for spec in IDENTIFIER_PARAMETERS]
    for spec in IDENTIFIER_PARAMETERS:
        value = values[spec.name]
        expected = tuple(spec.default) if isinstance(spec.default, list) else spec.default
        assert value == expected and type(value) is type(expected), spec.name


def test_the_node_config_file_gives_the_defaults() -> None:
    assert IdentifierSettings.from_yaml(config_path('identifier.yaml')) == \
        IdentifierSettings.defaults()


def test_a_params_file_changes_what_it_names(tmp_path: Path) -> None:
    path = tmp_path / 'params.yaml'
    path.write_text('/**:\n  ros__parameters:\n    hidden_units: 20\n    use_sim_time: false\n'
                    'identifier:\n  ros__parameters:\n    joint_names: [a, b]\n'
                    '    lm_interval: 100\n    position_min: [-1, 0]\n    methods:\n')
    settings = IdentifierSettings.from_yaml(path)
    assert settings == IdentifierSettings.defaults(
        hidden_units=20, joint_names=['a', 'b'], lm_interval=100, position_min=[-1.0, 0.0])
    assert settings.joint_names == ('a', 'b') and settings.position_min == (-1.0, 0.0)
    assert settings.methods == ()


@pytest.mark.parametrize('name, message', [
    ('lm_intervall', "'lm_intervall' is no parameter of the identifier$"),
    ('capacity', "'capacity' is no parameter of the identifier: it is called "
                 "'reservoir_size'"),
    ('steps_per_update', "it is called 'lm_steps'"),
])
def test_an_unknown_or_old_name_is_one_line_naming_it(name: str, message: str) -> None:
    with pytest.raises(ValueError, match=message) as caught:
        IdentifierSettings.defaults(**{name: 1})
    assert '\n' not in str(caught.value)
    with pytest.raises(SettingsError, match=message):
        IdentifierSettings.defaults().replace(**{name: 1})


def test_a_bad_value_is_one_line_naming_the_parameter(tmp_path: Path) -> None:
    with pytest.raises(SettingsError, match="parameter 'method' must be one of"):
        IdentifierSettings.defaults(method='ffx')
    with pytest.raises(SettingsError, match="parameter 'reservoir_size' must be >= 10"):
        IdentifierSettings.defaults().replace(reservoir_size=5)
    path = tmp_path / 'params.yaml'
    path.write_text('/**:\n  ros__parameters:\n    lm_steps: 0\n')
    with pytest.raises(SettingsError, match=f"{path}: parameter 'lm_steps' must be >= 1"):
        IdentifierSettings.from_yaml(path)


def test_replace_keeps_the_rest_and_the_settings_are_frozen() -> None:
    settings = IdentifierSettings.defaults(seed=3)
    changed = settings.replace(learn=False, learning_rate=1)
    assert (changed.seed, changed.learn, changed.learning_rate) == (3, False, 1.0)
    assert isinstance(changed.learning_rate, float) and settings.learn
    with pytest.raises(AttributeError):
        settings.seed = 4  # type: ignore[misc]
