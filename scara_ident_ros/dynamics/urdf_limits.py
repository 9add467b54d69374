"""Joint limits from a URDF: a file, or the ``robot_description`` string a robot publishes.

Reads ``<joint><limit lower upper velocity effort/>`` of every revolute and prismatic
joint, in document order, with the standard library's XML parser. URDF has no
acceleration limit: :meth:`~scara_ident_ros.dynamics.joint_limits.JointLimits.from_urdf`
adds those from elsewhere.

Continuous joints (no position range) and joints without a ``<limit>`` cannot scale a
network's inputs: they are listed in :attr:`UrdfLimits.unlimited`, not in the limits.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.errors import ScaraIdentError

__all__ = ['UrdfError', 'UrdfLimits', 'parse_urdf', 'read_urdf', 'LIMITED_TYPES']

#: Joint types whose ``<limit>`` gives a position range, a velocity and an effort limit.
LIMITED_TYPES = ('revolute', 'prismatic')
_ACTUATED_TYPES = (*LIMITED_TYPES, 'continuous')  # the others (fixed, floating, planar): none


class UrdfError(ScaraIdentError, ValueError):
    """A URDF that cannot be read, or whose joint limits are unusable; says where."""


@dataclass(frozen=True)
class UrdfLimits:
    """The joint limits of a URDF, in document order.

    Attributes
    ----------
    source : str
        Where the URDF came from (a path, or ``'robot_description'``), for messages.
    names : tuple of str of length n
        The revolute and prismatic joints with a ``<limit>``.
    position_min, position_max : ndarray of shape (n,)
        ``lower`` and ``upper`` (rad or m).
    velocity_max, effort_max : ndarray of shape (n,)
        ``velocity`` (rad/s or m/s) and ``effort`` (N·m or N).
    unlimited : dict of str to str
        Actuated joints left out, with why (``'continuous'``, ``'no <limit>'``).
    """

    source: str
    names: tuple[str, ...]
    position_min: NDArray[np.float64]
    position_max: NDArray[np.float64]
    velocity_max: NDArray[np.float64]
    effort_max: NDArray[np.float64]
    unlimited: dict[str, str] = field(default_factory=dict)

    def select(self, names: Sequence[str]) -> UrdfLimits:
        """The limits of ``names``, in that order.

        Raises
        ------
        UrdfError
            Naming every joint of ``names`` that has no limits here, and why.
        """
        missing = [name for name in names if name not in self.names]
        if missing:
            why = ', '.join(f'{name} ({self.unlimited.get(name, "not in the URDF")})'
                            for name in missing)
            raise UrdfError(f'{self.source}: no joint limits for {why}; the URDF has limits '
                            f'for {list(self.names)}')
        order = [self.names.index(name) for name in names]
        return UrdfLimits(self.source, tuple(names), self.position_min[order],
                          self.position_max[order], self.velocity_max[order],
                          self.effort_max[order])


def read_urdf(path: str | Path) -> UrdfLimits:
    """Read the joint limits of the URDF file at ``path`` (see :func:`parse_urdf`)."""
    try:
        text = Path(path).read_text(encoding='utf-8')
    except (OSError, UnicodeDecodeError) as exc:
        raise UrdfError(f'{path}: cannot read the URDF: {exc}') from None
    return parse_urdf(text, source=str(path))


def parse_urdf(text: str, *, source: str = 'robot_description') -> UrdfLimits:
    """Read the joint limits of a URDF document.

    ``source`` (where it came from) prefixes every error message.

    Raises
    ------
    UrdfError
        For text that is not XML, a root other than ``<robot>``, a joint without a name or
        type, a name used twice, or a revolute or prismatic joint whose limits are missing,
        not numbers, not finite, with ``lower >= upper`` or a velocity or effort <= 0.
    """
    if not text.strip():
        raise UrdfError(f'{source}: empty URDF')
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise UrdfError(f'{source}: not valid XML: {exc}') from None
    if root.tag != 'robot':
        raise UrdfError(f'{source}: the root element is <{root.tag}>, not <robot>: not a URDF')
    names: list[str] = []
    rows: list[tuple[float, float, float, float]] = []
    unlimited: dict[str, str] = {}
    seen: set[str] = set()
    for joint in root.findall('joint'):
        name, kind = joint.get('name'), joint.get('type')
        if not name or not kind:
            raise UrdfError(f'{source}: a <joint> without a name or type '
                            f'({ET.tostring(joint, encoding="unicode")[:80]!r})')
        if name in seen:
            raise UrdfError(f'{source}: joint {name!r} is defined twice')
        seen.add(name)
        if kind not in _ACTUATED_TYPES:
            continue
        limit = joint.find('limit')
        if kind == 'continuous' or limit is None:
            unlimited[name] = 'continuous' if kind == 'continuous' else 'no <limit>'
            continue
        rows.append(_limit_row(limit, f'{source}: joint {name!r}'))
        names.append(name)
    values = np.array(rows, dtype=float).reshape(len(rows), 4).T.copy()  # (4, n)
    return UrdfLimits(source, tuple(names), values[0], values[1], values[2], values[3],
                      unlimited)


def _limit_row(limit: ET.Element, where: str) -> tuple[float, float, float, float]:
    """lower, upper, velocity, effort of one ``<limit>``, checked."""
    values = []
    for attribute in ('lower', 'upper', 'velocity', 'effort'):
        text = limit.get(attribute)
        if text is None:  # URDF's default lower = upper = 0 is no range: refuse it
            raise UrdfError(f'{where}: <limit> has no {attribute!r}')
        try:
            value = float(text)
        except ValueError:
            raise UrdfError(f'{where}: <limit {attribute}="{text}"> is not a number') from None
        if not math.isfinite(value):
            raise UrdfError(f'{where}: <limit {attribute}="{text}"> is not finite')
        values.append(value)
    lower, upper, velocity, effort = values
    if lower >= upper:
        raise UrdfError(f'{where}: lower limit {lower:g} is not below upper {upper:g}')
    if velocity <= 0.0 or effort <= 0.0:
        raise UrdfError(f'{where}: velocity and effort limits must be > 0, got '
                        f'{velocity:g} and {effort:g}')
    return lower, upper, velocity, effort
