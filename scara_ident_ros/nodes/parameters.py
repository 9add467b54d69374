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

from collections.abc import Callable, Sequence
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from scara_ident_ros.errors import ConfigError
from scara_ident_ros.parameter_spec import ParamSpec

__all__ = ['ParamSpec', 'declare_parameters']


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
