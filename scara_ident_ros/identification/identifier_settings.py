"""An identifier's settings, typed: :class:`IdentifierSettings`, one field per parameter.

The fields are the ``identifier`` node's parameters, by the same names, and their defaults
are those of its table (:data:`~scara_ident_ros.identification.parameters.
IDENTIFIER_PARAMETERS`, the one place a default is written): the node converts its declared
parameters once (:meth:`IdentifierSettings.of`), a script starts from the defaults
(:meth:`IdentifierSettings.defaults`) or a ROS parameters file
(:meth:`IdentifierSettings.from_yaml`); the session, the builder and the core read its
attributes::

    settings = IdentifierSettings.defaults(method='ffs', seed=3)
    identifier = build_identifier(names, settings, limits)
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from scara_ident_ros.errors import ConfigError
from scara_ident_ros.identification.parameters import IDENTIFIER_PARAMETERS
from scara_ident_ros.parameter_spec import ParamSpec

__all__ = ['OLD_NAMES', 'IdentifierSettings', 'SettingsError']

#: Names the settings had on their way down before they took the parameter's, and the
#: parameter's name now.
OLD_NAMES = {'capacity': 'reservoir_size', 'steps': 'lm_steps',
             'steps_per_update': 'lm_steps'}
#: Parameters accepted in a parameters file and not settings: every ROS node's, and the
#: identifier node's own (nodes/identifier.py: its stream's end, its threads' scheduling,
#: the nodes it waits for)
ROS_PARAMETERS = ('use_sim_time', 'end_history_after', 'realtime_priority', 'wait_for_nodes')
_SPECS: dict[str, ParamSpec] = {spec.name: spec for spec in IDENTIFIER_PARAMETERS}


class SettingsError(ConfigError, ValueError):
    """A setting that is no parameter of the identifier, or a value its rules refuse."""


@dataclass(frozen=True)
class IdentifierSettings:
    """The ``identifier`` node's parameters by name (docs/parameters.md says what each
    means, its unit and range); lists are tuples. Build with :meth:`defaults`, :meth:`of`
    or :meth:`from_yaml` (each checks names and values), change with :meth:`replace`."""

    # the model
    method: str
    methods: tuple[str, ...]
    joint_names: tuple[str, ...]
    min_joints: int
    hidden_units: int
    seed: int
    learning_rate: float
    momentum: float
    k: float
    a: float
    b: float
    # learning
    learn: bool
    trainer: str
    reservoir_size: int
    lm_steps: int
    lm_interval: int
    lm_background: bool
    lm_nice: int
    lm_float64: bool
    lm_slow_share: float
    lm_friction_steps: bool
    kernel_features: int
    gp_budget: int
    learner_batch: int
    learner_warmup: int
    validation_fraction: float
    validation_block: int
    # files and outputs
    model_path: str
    save_path: str
    checkpoint_period: float
    mse_window: int
    mse_rate_hz: float
    # the samples: q'' estimate and checks
    differentiator: str
    derive_velocity: str
    cutoff_hz: float
    window: int
    limit_margin: float
    max_gap: float
    # the robot's limits
    robot_config: str
    urdf_file: str
    robot_description: str
    position_min: tuple[float, ...]
    position_max: tuple[float, ...]
    velocity_max: tuple[float, ...]
    acceleration_max: tuple[float, ...]
    effort_max: tuple[float, ...]
    # the node
    wait_for_subscribers: int
    wait_timeout: float
    stats_file: str
    # contact detection
    contact_false_alarms_per_hour: float
    contact_calibration: str
    contact_calibration_window: float
    contact_sigma: float
    contact_arm_nmse: float
    contact_envelope_margin: float
    contact_envelope_acceleration: bool
    contact_calibration_period: float
    contact_min_samples: int
    external_torque: bool

    @classmethod
    def of(cls, values: Mapping[str, object]) -> IdentifierSettings:
        """The settings of ``values`` by parameter name (e.g. the node's declared
        parameters); a parameter not among them takes its default.

        Raises
        ------
        SettingsError
            If a name is no parameter (an old name: saying the new one) or a value breaks
            its parameter's rules; one line naming the parameter.
        """
        for name in values:
            if name not in _SPECS:
                new = OLD_NAMES.get(name)
                raise SettingsError(f"'{name}' is no parameter of the identifier"
                                    + (f": it is called '{new}'" if new else ''))
        return cls(**{spec.name: _value(spec, values.get(spec.name, spec.default))
                      for spec in IDENTIFIER_PARAMETERS})

    @classmethod
    def defaults(cls, **changes: object) -> IdentifierSettings:
        """The node's defaults, with ``changes`` (parameter names) instead of some."""
        return cls.of(changes)

    @classmethod
    def from_yaml(cls, path: str | Path, node: str = 'identifier') -> IdentifierSettings:
        """The settings of a ROS parameters file (``/**:`` or ``<node>:`` then
        ``ros__parameters:``, the node's section over the wildcard's), the others the
        defaults."""
        try:
            data = yaml.safe_load(Path(path).read_text(encoding='utf-8')) or {}
        except (OSError, yaml.YAMLError) as exc:
            raise SettingsError(f'{path}: cannot read it: {exc}') from None
        values: dict[str, object] = {}
        for key in ('/**', node, f'/{node}'):
            section = data.get(key) if isinstance(data, dict) else None
            if isinstance(section, dict):
                values.update(section.get('ros__parameters') or {})
        for name in ROS_PARAMETERS:
            values.pop(name, None)
        try:
            return cls.of(values)
        except SettingsError as exc:
            raise SettingsError(f'{path}: {exc}') from None

    def replace(self, **changes: object) -> IdentifierSettings:
        """These settings with ``changes`` (parameter names), checked as :meth:`of`."""
        return self.of({**self.as_dict(), **changes})

    def as_dict(self) -> dict[str, object]:
        """The settings by parameter name (lists as tuples)."""
        return {field.name: getattr(self, field.name) for field in fields(self)}


def _value(spec: ParamSpec, value: Any) -> Any:
    """``value`` checked by ``spec`` and of the field's type: a number where a float is
    declared a float, a list a tuple (None, an empty list in a parameters file: empty)."""
    if value is None and spec.default == []:
        value = ()
    why = spec.check(value)
    if why is not None:
        raise SettingsError(f"parameter '{spec.name}' {why}")
    if isinstance(spec.default, float):
        return float(value)
    if spec.items is not None:
        return tuple(spec.items(item) for item in value)
    return value


def _check_fields() -> None:
    """The dataclass has a field for every parameter of the table, and no other."""
    names = [field.name for field in fields(IdentifierSettings)]
    if names != list(_SPECS):
        raise AssertionError('IdentifierSettings and IDENTIFIER_PARAMETERS differ: '
                             f'{sorted(set(names) ^ set(_SPECS))}')


_check_fields()
