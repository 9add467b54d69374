"""Declare a node's parameters once, from a table of :class:`ParamSpec`.

Each parameter gets a descriptor (description with its unit, numeric range,
read-only flag) and is validated when declared (overrides from ``-p`` or a
``--params-file``) and whenever it is set later; a bad value raises
:class:`~scara_ident_ros.errors.ConfigError` naming the parameter, and a bad
``ros2 param set`` is refused with the same reason. Parameters declared with
``read_only=False`` can be set while the node runs: ``on_change`` of
:func:`declare_parameters` is then called with the new values, to apply them; the
description of every other one says why it is fixed at start.
"""
from __future__ import annotations

import array
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from scara_ident_ros.errors import ConfigError

__all__ = ['ParamSpec', 'declare_parameters']


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: name, default (its type is the parameter's type) and rules."""

    name: str
    default: Any
    description: str
    unit: str = ''
    min: float | None = None  # inclusive
    max: float | None = None  # inclusive
    choices: tuple[str, ...] | None = None
    read_only: bool = True
    items: type | None = None  # element type of a list parameter (str or float)
    fixed: str = ''  # why a read-only parameter cannot change while the node runs

    def descriptor(self) -> ParameterDescriptor:
        """Return the ROS descriptor shown by ``ros2 param describe``."""
        text = self.description + (f' [{self.unit}]' if self.unit else '')
        if self.choices:
            text += f" (one of: {', '.join(self.choices)})"
        if self.read_only:
            text += f" (fixed at start{': ' + self.fixed if self.fixed else ''})"
        else:
            text += ' (settable while running)'
        # An empty list has no ROS type of its own, and `-p rate_hz:=1000` is an integer
        # where a float is declared: let the override decide the type, then check it.
        descriptor = ParameterDescriptor(
            description=text, read_only=self.read_only,
            dynamic_typing=self.default == [] or isinstance(self.default, float))
        if self.min is not None or self.max is not None:
            low = self.min if self.min is not None else -1e308
            high = self.max if self.max is not None else 1e308
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                descriptor.integer_range = [IntegerRange(
                    from_value=int(max(low, -2**63)), to_value=int(min(high, 2**63 - 1)))]
            elif isinstance(self.default, float):
                descriptor.floating_point_range = [
                    FloatingPointRange(from_value=float(low), to_value=float(high))]
        return descriptor

    def check(self, value: Any) -> str | None:
        """Return why ``value`` is not acceptable, or None if it is."""
        if value is None and self.default == []:
            return None  # `name: []` in a params file: rcl reads an empty list as not set
        if isinstance(self.default, float) and (
                isinstance(value, bool) or not isinstance(value, (int, float))):
            return f'must be a number, got {value!r}'
        if isinstance(value, float) and not math.isfinite(value):
            return f'must be finite, got {value}'
        if self.items is not None:
            if not isinstance(value, (list, tuple, array.array)) or not all(
                    isinstance(item, self.items) or (self.items is float
                                                     and isinstance(item, int))
                    for item in value):
                return f'must be a list of {self.items.__name__}, got {value!r}'
            if self.items is float and not all(math.isfinite(item) for item in value):
                return f'must be a list of finite numbers, got {list(value)!r}'
        if self.choices is not None and self.items is not None:
            if not all(item in self.choices for item in value):
                return f"must list only {', '.join(self.choices)}, got {list(value)!r}"
        elif self.choices is not None and value not in self.choices:
            return f"must be one of {', '.join(self.choices)}, got {value!r}"
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if self.min is not None and value < self.min:
                return f'must be >= {self.min}, got {value}'
            if self.max is not None and value > self.max:
                return f'must be <= {self.max}, got {value}'
        return None


def declare_parameters(node: Node, specs: Sequence[ParamSpec], *,
                       on_change: Callable[[dict[str, Any]], None] | None = None
                       ) -> dict[str, Any]:
    """Declare ``specs`` on ``node`` and return their values by name.

    The returned dict stays current: a value set later (only the specs with
    ``read_only=False`` can be), once it passed its spec's check, replaces the old one in
    it, and then ``on_change`` is called with the changed values by name (in the thread
    that spins the node) to make them take effect.

    Raises
    ------
    ConfigError
        If an override has the wrong type or fails a spec's rule; the message
        names the parameter.
    """
    by_name = {spec.name: spec for spec in specs}

    def on_set(parameters: list[Parameter]) -> SetParametersResult:
        for parameter in parameters:
            spec = by_name.get(parameter.name)
            reason = spec.check(parameter.value) if spec is not None else None
            if reason is not None:
                return SetParametersResult(successful=False,
                                           reason=f"parameter '{parameter.name}' {reason}")
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
    values: dict[str, Any] = {}
    for spec in specs:
        try:
            values[spec.name] = node.declare_parameter(
                spec.name, spec.default, spec.descriptor()).value
        except ParameterException as exc:
            raise ConfigError(f"parameter '{spec.name}': {exc}") from None
        reason = spec.check(values[spec.name])
        if reason is not None:
            raise ConfigError(f"parameter '{spec.name}' {reason}")
        if isinstance(spec.default, float):
            values[spec.name] = float(values[spec.name])
        elif values[spec.name] is None and spec.default == []:
            values[spec.name] = []

    def on_set_done(parameters: list[Parameter]) -> None:
        changed = {p.name: _typed(by_name[p.name], p.value) for p in parameters
                   if p.name in by_name}
        values.update(changed)
        if on_change is not None and changed:
            on_change(changed)

    node.add_post_set_parameters_callback(on_set_done)  # after the declarations: sets only
    return values


def _typed(spec: ParamSpec, value: Any) -> Any:
    """``value`` as the spec's type (an integer set where a float is declared: float)."""
    if isinstance(spec.default, float):
        return float(value)
    if spec.items is not None:
        return list(value)
    return value
