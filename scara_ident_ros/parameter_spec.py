"""One parameter of a node: name, default, description, unit and rules (:class:`ParamSpec`).

A node's table of them is the one source of its parameters' defaults: the node declares
them (:func:`scara_ident_ros.nodes.parameters.declare_parameters`), ``config/<node>.yaml``
holds their defaults, docs/parameters.md is generated from them, and the core's settings
are built from them. Nothing here imports ROS but :meth:`ParamSpec.descriptor`.
"""
from __future__ import annotations

import array
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rcl_interfaces.msg import ParameterDescriptor

__all__ = ['ParamSpec']


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
        from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

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
