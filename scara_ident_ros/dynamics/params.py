"""Physical parameters and joint limits of the 4-DOF SCARA (RRP arm with a roll wrist).

The names, units and conventions are those of ``scara-model.md``: joint 1 and 2 turn about
vertical axes (counter-clockwise seen from above), joint 3 translates the quill downward
(positive down, in metres), joint 4 rolls the tool about the quill with its z axis pointing
down (positive clockwise seen from above). All values are SI.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from scara_ident_ros.errors import ScaraIdentError

__all__ = ['ParamError', 'ScaraParams', 'N_JOINTS', 'VECTOR_FIELDS']

N_JOINTS = 4

#: Fields holding one value per joint (stored as tuples of 4 floats).
VECTOR_FIELDS = ('viscous', 'coulomb', 'position_min', 'position_max', 'velocity_max',
                 'acceleration_max', 'effort_max')


class ParamError(ScaraIdentError, ValueError):
    """An invalid parameter: the message names the field, the offending value and why."""


# ---------------------------------------------------------------------------------------------
# validation helpers (shared with the simulator's configuration)

def _scalar(name: str, value: Any, *, minimum: float | None = None,
            strict: bool = True) -> float:
    """Return ``value`` as a finite float, checking ``value > minimum`` (or ``>=``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParamError(f'{name} must be a number, got {value!r}')
    number = float(value)
    if not math.isfinite(number):
        raise ParamError(f'{name} must be finite, got {number!r}')
    if minimum is not None:
        if strict and not number > minimum:
            raise ParamError(f'{name} must be > {minimum:g}, got {number!r}')
        if not strict and not number >= minimum:
            raise ParamError(f'{name} must be >= {minimum:g}, got {number!r}')
    return number


def _vector4(name: str, value: Any, *, minimum: float | None = None, strict: bool = True,
             allow_scalar: bool = False) -> tuple[float, float, float, float]:
    """Return ``value`` as a tuple of 4 finite floats, each checked like :func:`_scalar`."""
    items = _vector(name, value, N_JOINTS, minimum=minimum, strict=strict,
                    allow_scalar=allow_scalar)
    return items  # type: ignore[return-value]


def _vector(name: str, value: Any, n: int, *, minimum: float | None = None,
            strict: bool = True, allow_scalar: bool = False) -> tuple[float, ...]:
    """Return ``value`` as a tuple of ``n`` finite floats, each checked like :func:`_scalar`."""
    if allow_scalar and not isinstance(value, (str, bytes)) and np.ndim(value) == 0:
        value = [value] * n
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ParamError(f'{name} must be a sequence of {n} numbers, got {value!r}')
    if len(value) != n:
        raise ParamError(f'{name} must have {n} values, got {len(value)}: {value!r}')
    return tuple(_scalar(f'{name}[{i}]', v, minimum=minimum, strict=strict)
                 for i, v in enumerate(value))


def _integer(name: str, value: Any, *, minimum: int) -> int:
    """Return ``value`` as an int ``>= minimum``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParamError(f'{name} must be an integer, got {value!r}')
    if value < minimum:
        raise ParamError(f'{name} must be >= {minimum}, got {value!r}')
    return int(value)


def _check_keys(cls: type, mapping: Any, origin: str) -> dict[str, Any]:
    """Check that ``mapping`` is a mapping whose keys are all fields of dataclass ``cls``."""
    if not isinstance(mapping, Mapping):
        raise ParamError(f'{origin}: expected a mapping of parameter names to values, '
                         f'got {type(mapping).__name__}')
    known = {f.name for f in fields(cls)}
    unknown = sorted(str(k) for k in mapping if k not in known)
    if unknown:
        raise ParamError(f'{origin}: unknown parameter(s) {", ".join(unknown)}; '
                         f'known are {", ".join(sorted(known))}')
    return dict(mapping)


def _load_yaml_mapping(path: str | Path) -> Any:
    """Read a YAML file, turning I/O and syntax errors into :class:`ParamError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except OSError as exc:
        raise ParamError(f'{path}: cannot read parameter file ({exc.strerror})') from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ParamError(f'{path}: invalid YAML ({exc})') from exc
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ParamError(f'{path}: expected a YAML mapping of parameter names to values, '
                         f'got {type(data).__name__}')
    return data


# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ScaraParams:
    """Inertial, friction and limit parameters of the SCARA, in SI units.

    The defaults describe an industrial SCARA of the Epson/Adept class with a 0.65 m reach,
    a 0.2 m quill stroke and a 2 kg payload included in ``m4``/``izz4``.

    Attributes
    ----------
    l1, l2 : float
        Link lengths, D-H ``a1`` and ``a2`` (m).
    lc1, lc2 : float
        Distance from the joint axis to the link's centre of mass, along the link (m),
        ``0 <= lc_i <= l_i``.
    m1, m2 : float
        Link masses (kg).
    m3 : float
        Mass moved by joint 3, the quill (kg).
    m4 : float
        Mass moved by joint 4, wrist, tool and payload; centre of mass on the quill axis (kg).
    izz1, izz2, izz3, izz4 : float
        Moment of inertia of body i about the vertical axis through its own centre of mass
        (kg·m²).
    d4 : float
        Fixed tool offset along the quill, D-H ``d4`` (m).
    gravity : float
        Magnitude of the gravitational acceleration, acting along -z (m/s²).
    viscous : tuple of 4 float
        Viscous friction coefficient per joint (N·m·s/rad, N·s/m for joint 3).
    coulomb : tuple of 4 float
        Coulomb friction level per joint (N·m, N for joint 3).
    coulomb_eps : float
        Velocity scale of the smooth sign ``tanh(qd / coulomb_eps)`` of the Coulomb term
        (rad/s, m/s for joint 3).
    joint_names : tuple of 4 str
        Joint names on the wire.
    position_min, position_max : tuple of 4 float
        Joint position limits (rad, rad, m, rad).
    velocity_max : tuple of 4 float
        Joint speed limits, symmetric (rad/s, rad/s, m/s, rad/s).
    acceleration_max : tuple of 4 float
        Joint acceleration limits, symmetric (rad/s², rad/s², m/s², rad/s²).
    effort_max : tuple of 4 float
        Actuator effort limits, symmetric (N·m, N·m, N, N·m).
    """

    l1: float = 0.40              # m, link 1 length (D-H a1)
    l2: float = 0.25              # m, link 2 length (D-H a2)
    lc1: float = 0.22             # m, joint 1 axis to link 1 centre of mass
    lc2: float = 0.14             # m, joint 2 axis to link 2 centre of mass
    m1: float = 8.0               # kg, link 1 (with the joint-2 motor)
    m2: float = 5.0               # kg, link 2 (with the joint-3/4 drives)
    m3: float = 1.5               # kg, quill (ball-screw spline shaft)
    m4: float = 3.0               # kg, wrist + tool + 2 kg payload
    izz1: float = 0.12            # kg·m², link 1 about its centre of mass
    izz2: float = 0.04            # kg·m², link 2 about its centre of mass
    izz3: float = 0.002           # kg·m², quill about its axis
    izz4: float = 0.012           # kg·m², wrist + tool + payload about the quill axis
    d4: float = 0.05              # m, tool offset along the quill
    gravity: float = 9.81         # m/s²
    viscous: tuple[float, ...] = (3.0, 1.5, 20.0, 0.05)       # N·m·s/rad, N·s/m (joint 3)
    coulomb: tuple[float, ...] = (6.0, 3.0, 15.0, 0.5)        # N·m, N (joint 3)
    coulomb_eps: float = 0.05     # rad/s (m/s), velocity scale of tanh(qd / eps)
    joint_names: tuple[str, ...] = ('joint1', 'joint2', 'joint3', 'joint4')
    position_min: tuple[float, ...] = (-2.3, -2.5, 0.0, -6.28)     # rad, rad, m, rad
    position_max: tuple[float, ...] = (2.3, 2.5, 0.2, 6.28)        # rad, rad, m, rad
    velocity_max: tuple[float, ...] = (7.0, 12.0, 1.1, 26.0)       # rad/s, rad/s, m/s, rad/s
    acceleration_max: tuple[float, ...] = (30.0, 50.0, 10.0, 150.0)  # rad/s², m/s² (joint 3)
    effort_max: tuple[float, ...] = (250.0, 100.0, 250.0, 10.0)    # N·m, N·m, N, N·m

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in ('l1', 'l2', 'm1', 'm2', 'm3', 'm4', 'izz1', 'izz2', 'izz3', 'izz4',
                     'coulomb_eps'):
            set_(self, name, _scalar(name, getattr(self, name), minimum=0.0))
        for name in ('lc1', 'lc2', 'gravity'):
            set_(self, name, _scalar(name, getattr(self, name), minimum=0.0, strict=False))
        set_(self, 'd4', _scalar('d4', self.d4))
        if self.lc1 > self.l1:
            raise ParamError(f'lc1 must be <= l1 = {self.l1!r} (within link 1), '
                             f'got {self.lc1!r}')
        if self.lc2 > self.l2:
            raise ParamError(f'lc2 must be <= l2 = {self.l2!r} (within link 2), '
                             f'got {self.lc2!r}')
        for name in ('viscous', 'coulomb'):
            set_(self, name, _vector4(name, getattr(self, name), minimum=0.0, strict=False))
        for name in ('position_min', 'position_max'):
            set_(self, name, _vector4(name, getattr(self, name)))
        for name in ('velocity_max', 'acceleration_max', 'effort_max'):
            set_(self, name, _vector4(name, getattr(self, name), minimum=0.0))
        for i, (low, high) in enumerate(zip(self.position_min, self.position_max)):
            if not low < high:
                raise ParamError(f'position_min[{i}] must be < position_max[{i}], '
                                 f'got {low!r} >= {high!r}')
        names = self.joint_names
        if (isinstance(names, (str, bytes)) or not isinstance(names, Sequence)
                or len(names) != N_JOINTS):
            raise ParamError(f'joint_names must be a sequence of {N_JOINTS} names, '
                             f'got {names!r}')
        if not all(isinstance(n, str) and n for n in names):
            raise ParamError(f'joint_names must be non-empty strings, got {names!r}')
        if len(set(names)) != N_JOINTS:
            raise ParamError(f'joint_names must be unique, got {names!r}')
        set_(self, 'joint_names', tuple(names))

    # -- numpy accessors ----------------------------------------------------------------------

    def array(self, name: str) -> np.ndarray:
        """Return the per-joint field ``name`` as a new float array of shape (4,)."""
        if name not in VECTOR_FIELDS:
            raise ParamError(f'{name} is not a per-joint field; those are '
                             f'{", ".join(VECTOR_FIELDS)}')
        return np.array(getattr(self, name), dtype=float)

    @property
    def position_centre(self) -> np.ndarray:
        """Middle of each joint's range, shape (4,) (rad, rad, m, rad)."""
        return 0.5 * (self.array('position_min') + self.array('position_max'))

    # -- conversions ---------------------------------------------------------------------------

    @classmethod
    def from_dict(cls, mapping: Mapping[str, Any]) -> ScaraParams:
        """Build parameters from a mapping; missing names take the defaults.

        Raises
        ------
        ParamError
            If ``mapping`` is not a mapping, holds unknown names or invalid values.
        """
        return cls(**_check_keys(cls, mapping, cls.__name__))

    @classmethod
    def from_yaml(cls, path: str | Path) -> ScaraParams:
        """Read parameters from a plain YAML mapping (see ``config/scara.yaml``).

        A robot file names every parameter: a forgotten or misspelt one must not silently
        take the default of another robot (unlike :meth:`from_dict`).

        Raises
        ------
        ParamError
            If the file is missing or unreadable, is not a YAML mapping, lacks a parameter,
            or holds unknown names or invalid values; the message names the path.
        """
        data = _check_keys(cls, _load_yaml_mapping(path), str(path))
        missing = [f.name for f in fields(cls) if f.name not in data]
        if missing:
            raise ParamError(f'{path}: missing parameter(s) {", ".join(missing)}; a robot '
                             'file names every parameter (see config/scara.yaml)')
        try:
            return cls(**data)
        except ParamError as exc:
            if str(exc).startswith(str(path)):
                raise
            raise ParamError(f'{path}: {exc}') from exc

    def to_dict(self) -> dict[str, Any]:
        """Return the parameters as plain Python values (lists for the per-joint fields)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            out[f.name] = list(value) if isinstance(value, tuple) else value
        return out

    def perturbed(self, relative: float, *, seed: int) -> ScaraParams:
        """Return a copy with masses, inertias, centre-of-mass distances and friction scaled.

        Each is multiplied by ``1 + relative * u``, ``u`` uniform in [-1, 1] (seeded),
        ``0 <= relative < 1``; geometry, gravity and limits are unchanged. It gives a
        controller a model mismatch.
        """
        relative = _scalar('relative', relative, minimum=0.0, strict=False)
        if relative >= 1.0:
            raise ParamError(f'relative must be < 1, got {relative!r}')
        rng = np.random.default_rng(seed)
        changes: dict[str, Any] = {}
        for name in ('m1', 'm2', 'm3', 'm4', 'izz1', 'izz2', 'izz3', 'izz4'):
            changes[name] = getattr(self, name) * (1.0 + relative * rng.uniform(-1.0, 1.0))
        for name, link in (('lc1', 'l1'), ('lc2', 'l2')):
            scaled = getattr(self, name) * (1.0 + relative * rng.uniform(-1.0, 1.0))
            changes[name] = min(scaled, getattr(self, link))
        for name in ('viscous', 'coulomb'):
            factors = 1.0 + relative * rng.uniform(-1.0, 1.0, N_JOINTS)
            changes[name] = tuple(float(v) for v in self.array(name) * factors)
        return replace(self, **changes)
