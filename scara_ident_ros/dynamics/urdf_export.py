"""A physical model's identified parameters written back into its URDF.

The model was built from a URDF; its physically consistent standard parameters
(:meth:`PhysicalModel.consistent_standard`: 10 per body, about the body's joint frame,
which in a URDF is the child link's frame) become each body's ``<inertial>`` (mass, centre
of mass, inertia about it), and its viscous and Coulomb friction the modelled joints'
``<dynamics damping= friction=>``. Pinocchio merges the links fixed to a body (and those of
joints the model locks) into that body: their identified share is in the body's inertial,
so their own ``<inertial>`` is removed. Everything else of the URDF (visuals, limits,
other joints) is kept as it was.

What a URDF cannot hold is written in a comment at the top of the robot: rotor inertias
(Pinocchio's ``model.armature``, which its URDF parser leaves at 0), asymmetric, Stribeck
and coupled friction, effort offsets. Loaded in Pinocchio (the modelled joints free, the
others locked at neutral), the URDF's ``rnea`` is the model's rigid-body effort
(:func:`rigid_body_effort`).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scara_ident_ros.dynamics.physical_model import PhysicalModel

__all__ = ['model_to_urdf', 'rigid_body_effort']

FloatArray = NDArray[np.float64]


def rigid_body_effort(model: PhysicalModel, standard: ArrayLike, q: ArrayLike, qd: ArrayLike,
                      qdd: ArrayLike) -> FloatArray:
    """The rigid bodies' efforts (no rotor inertia, no friction) of standard parameters.

    Parameters
    ----------
    standard : array_like of shape (P,)
        Standard parameters (:attr:`PhysicalModel.standard_names`).
    q, qd, qdd : array_like of shape (N, n)
        States (SI).

    Returns
    -------
    ndarray of shape (N, n)
        N·m or N.
    """
    inertial = 10 * model.n_bodies
    w = model.standard_regressor(np.atleast_2d(q), np.atleast_2d(qd), np.atleast_2d(qdd))
    return np.asarray(w[..., :inertial] @ np.asarray(standard, np.float64)[:inertial])


def model_to_urdf(model: PhysicalModel, standard: ArrayLike | None = None) -> str:
    """The model's URDF with its identified inertials and friction (module docstring).

    Parameters
    ----------
    model : PhysicalModel
        A fitted model.
    standard : array_like of shape (P,), optional
        Physically consistent standard parameters; default
        :meth:`PhysicalModel.consistent_standard`.

    Returns
    -------
    str
        The URDF document.
    """
    values = (model.consistent_standard() if standard is None
              else np.asarray(standard, dtype=np.float64))
    root = ET.fromstring(model.urdf)
    links = {link.get('name'): link for link in root.findall('link')}
    joints = {joint.get('name'): joint for joint in root.findall('joint')}
    parent: dict[str | None, tuple[ET.Element, str | None]] = {}
    for joint in joints.values():
        child, above = joint.find('child'), joint.find('parent')
        if child is not None and above is not None:
            parent[child.get('link')] = (joint, above.get('link'))
    bodies = {name: k for k, name in enumerate(model.body_names)}
    modelled = set(model.joint_names)
    for name, link in links.items():
        if name in bodies:
            _set_inertial(link, values[10 * bodies[name]:10 * bodies[name] + 10])
            continue
        owner = name  # the body Pinocchio merges this link into, if any
        while owner in parent and owner not in bodies:
            joint, owner = parent[owner]
            if joint.get('name') in modelled:
                owner = None
        if owner in bodies and link.find('inertial') is not None:
            link.remove(link.find('inertial'))  # type: ignore[arg-type]
    for name, viscous, coulomb in zip(model.joint_names, model.viscous,
                                      model.coulomb_friction):
        joint = joints[name]
        dynamics = joint.find('dynamics')
        if dynamics is None:
            dynamics = ET.SubElement(joint, 'dynamics')
        dynamics.set('damping', _number(viscous))
        dynamics.set('friction', _number(coulomb))
    root.insert(0, ET.Comment(_note(model, values)))
    ET.indent(root)
    return ET.tostring(root, encoding='unicode', xml_declaration=True) + '\n'


def _set_inertial(link: ET.Element, parameters: FloatArray) -> None:
    """Replace ``link``'s inertial by the body of 10 standard parameters (joint frame)."""
    m = float(parameters[0])
    com = parameters[1:4] / m
    ixx, ixy, iyy, ixz, iyz, izz = parameters[4:]
    about = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    central = about - m * (np.dot(com, com) * np.eye(3) - np.outer(com, com))
    old = link.find('inertial')
    index = list(link).index(old) if old is not None else len(link)
    if old is not None:
        link.remove(old)
    inertial = ET.Element('inertial')
    ET.SubElement(inertial, 'origin', xyz=' '.join(_number(v) for v in com), rpy='0 0 0')
    ET.SubElement(inertial, 'mass', value=_number(m))
    ET.SubElement(inertial, 'inertia', ixx=_number(central[0, 0]), ixy=_number(central[0, 1]),
                  ixz=_number(central[0, 2]), iyy=_number(central[1, 1]),
                  iyz=_number(central[1, 2]), izz=_number(central[2, 2]))
    link.insert(index, inertial)


def _note(model: PhysicalModel, standard: FloatArray) -> str:
    """The comment: where the parameters come from and what a URDF cannot hold."""
    first = model.n_base + 2 * model.n_joints
    lines = [' Inertials and joint friction identified by scara-ident (physically consistent',
             ' standard parameters). Not in URDF elements:']
    if model.armature:
        rotor = standard[10 * model.n_bodies:]
        lines.append(' rotor inertia (kg m^2, Pinocchio model.armature): ' + ', '.join(
            f'{name} {_number(v)}' for name, v in zip(model.joint_names, rotor)))
    if model.coulomb == 'sign':
        lines.append(' Coulomb friction shape: sign(qd)')
    else:
        lines.append(f' Coulomb friction shape: tanh(qd / {model.coulomb_eps:g})')
    lines += [f' {name} = {_number(v)}' for name, v in
              zip(model.parameter_names[first:], model.theta[first:])]
    return '\n'.join(lines) + '\n'


def _number(value: float) -> str:
    return f'{float(value):.17g}'
