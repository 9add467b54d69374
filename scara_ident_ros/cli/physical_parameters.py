"""A physical model's identified parameters as Markdown tables: base parameters, friction.

What ``scara-ident train`` and ``evaluate`` print for a physical or hybrid model: each base
parameter by name, its identified value, the value the URDF's inertias give (a check of the
description, and of the fit: they differ where the URDF is wrong or the data do not excite
a parameter) and what it is made of; then viscous and Coulomb friction per joint.
"""
from __future__ import annotations

from scara_ident_ros.dynamics.physical_model import PhysicalModel

__all__ = ['parameters_markdown']


def parameters_markdown(model: PhysicalModel) -> str:
    """Two Markdown tables: the base parameters, then friction per joint.

    Parameters
    ----------
    model : PhysicalModel
        A fitted model.
    """
    urdf = model.urdf_parameters()
    lines = ['| base parameter | identified | URDF | definition |', '|---|---|---|---|']
    for k, (name, definition) in enumerate(zip(model.parameter_names, model.definitions())):
        lines.append(f'| {name} | {_value(float(model.theta[k]))} | '
                     f'{_value(float(urdf[k]))} | {definition} |')
    lines += ['', f'Units: kg (m), kg·m (m·c), kg·m² (I, Ia: rotor inertia); moments about '
                  f'each joint\'s frame. Coulomb friction shape: {_shape(model)}.', '',
              '| joint | viscous (N·m·s/rad or N·s/m) | Coulomb (N·m or N) |', '|---|---|---|']
    for name, (viscous, coulomb) in model.friction.items():
        lines.append(f'| {name} | {_value(viscous)} | {_value(coulomb)} |')
    first = model.n_base + 2 * model.n_joints
    if model.n_parameters > first:  # Stribeck, asymmetric, coupled friction, offsets
        lines += ['', '| other friction and offsets | identified |', '|---|---|']
        lines += [f'| {name} | {_value(float(value))} |' for name, value in
                  zip(model.parameter_names[first:], model.theta[first:])]
    return '\n'.join(lines) + '\n'


def _value(value: float) -> str:
    return f'{value:.4g}'


def _shape(model: PhysicalModel) -> str:
    if model.coulomb == 'sign':
        return 'sign(qd)'
    return f'tanh(qd / {model.coulomb_eps:g})'
