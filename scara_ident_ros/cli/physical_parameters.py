"""A physical model's identified parameters as Markdown tables: base parameters, friction.

What ``scara-ident train`` and ``evaluate`` print for a physical or hybrid model: each base
parameter by name, its identified value, its relative standard deviation %σ (how well the
data determine it: :mod:`~scara_ident_ros.dynamics.parameter_uncertainty`), the value the
URDF's inertias give (a check of the description, and of the fit: they differ where the URDF
is wrong or the data do not excite a parameter) and what it is made of; then viscous and
Coulomb friction per joint with theirs; then the regressor's condition number and the
parameters the data do not determine (%σ above the threshold): what to excite more.
"""
from __future__ import annotations

import numpy as np

from scara_ident_ros.dynamics.parameter_uncertainty import UNDETERMINED_RELATIVE_STD
from scara_ident_ros.dynamics.physical_model import PhysicalModel

__all__ = ['parameters_markdown']


def parameters_markdown(model: PhysicalModel) -> str:
    """Markdown tables: the base parameters, then friction per joint, each with its %σ;
    then the condition number and the undetermined parameters, if the model has them.

    Parameters
    ----------
    model : PhysicalModel
        A fitted model.
    """
    urdf = model.urdf_parameters()
    found = model.uncertainty
    relative = (np.full(model.n_parameters, np.nan) if found is None
                else found.relative_std)
    lines = ['| base parameter | identified | URDF | %σ | definition |', '|---|---|---|---|---|']
    for k, (name, definition) in enumerate(zip(model.parameter_names, model.definitions())):
        lines.append(f'| {name} | {_value(float(model.theta[k]))} | {_value(float(urdf[k]))} | '
                     f'{_percent(relative[k])} | {definition} |')
    lines += ['', f'Units: kg (m), kg·m (m·c), kg·m² (I, Ia: rotor inertia); moments about '
                  f'each joint\'s frame. Coulomb friction shape: {_shape(model)}.', '',
              '| joint | viscous (N·m·s/rad or N·s/m) | %σ | Coulomb (N·m or N) | %σ |',
              '|---|---|---|---|---|']
    nb, n = model.n_base, model.n_joints
    for j, (name, (viscous, coulomb)) in enumerate(model.friction.items()):
        lines.append(f'| {name} | {_value(viscous)} | {_percent(relative[nb + j])} | '
                     f'{_value(coulomb)} | {_percent(relative[nb + n + j])} |')
    first = nb + 2 * n
    if model.n_parameters > first:  # Stribeck, asymmetric, coupled friction, offsets
        lines += ['', '| other friction and offsets | identified | %σ |', '|---|---|---|']
        lines += [f'| {name} | {_value(float(value))} | {_percent(r)} |' for name, value, r
                  in zip(model.parameter_names[first:], model.theta[first:], relative[first:])]
    if found is not None:
        lines += ['', f'Condition number of the regressor: {found.condition_number:.4g}. '
                      + _undetermined(found.undetermined_names)]
    return '\n'.join(lines) + '\n'


def _undetermined(names: tuple[str, ...]) -> str:
    limit = f'%σ > {100 * UNDETERMINED_RELATIVE_STD:g} %'
    if not names:
        return f'Every parameter is determined by the data ({limit} for none).'
    return (f'Not determined by the data ({limit}; excite the motion they act in more; '
            f'`export --urdf` keeps the URDF\'s values): {", ".join(names)}.')


def _percent(relative: float) -> str:
    if np.isnan(relative):
        return '—'
    return '∞' if np.isinf(relative) else f'{100 * relative:.2g}'


def _value(value: float) -> str:
    return f'{value:.4g}'


def _shape(model: PhysicalModel) -> str:
    if model.coulomb == 'sign':
        return 'sign(qd)'
    return f'tanh(qd / {model.coulomb_eps:g})'
