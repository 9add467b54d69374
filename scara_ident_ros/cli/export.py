"""``scara-ident export MODEL.npz --out MODEL.onnx``: a saved network as an ONNX model;
``scara-ident export MODEL.npz --urdf ROBOT.urdf``: a physical or hybrid model as a URDF.

Writes the network, scaling included, as a float64 ONNX model that ONNX Runtime (C++,
Python, ...) runs without this package: input ``x`` of shape (batch, 3n) holding the joint
positions, velocities and accelerations [q, q', q''] in SI units (rad, m, /s, /s²), output
``effort`` of shape (batch, n) in N·m or N. The model's metadata records the joint names
(comma-separated, when the .npz has them), the method and the package version.

Before writing, runs the ONNX model with ONNX Runtime on inputs drawn within the network's
input ranges (the joint limits of a model scaled from them) and refuses to write it if it
is further than 1e-6 (relative) from the package's own prediction. docs/onnx_export.md
shows how a ros2_control controller loads it.

--urdf: the identified parameters of a physical model (or a hybrid's physical part) written
into its URDF: per link the mass, centre of mass and inertia of physically consistent
standard parameters, per joint <dynamics damping= friction=> (viscous and Coulomb friction);
rotor inertias, effort offsets and other friction terms in a comment. A parameter the
training data did not determine (its %σ above the threshold of
:mod:`~scara_ident_ros.dynamics.parameter_uncertainty`) keeps the URDF's value (friction: 0),
its prior. Pinocchio, MoveIt and
robot_sim (-p urdf_file:=ROBOT.urdf) load it. Before writing, Pinocchio's rnea of the
written URDF is checked against the model's rigid-body efforts on random states (1e-6 of
the largest effort).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from scara_ident_ros.cli import CliError
from scara_ident_ros.paths import unwritable_file

if TYPE_CHECKING:
    from scara_ident_ros.dynamics.physical_model import PhysicalModel

__all__ = ['CHECK_SAMPLES', 'TOLERANCE', 'add_parser', 'run']

#: Random inputs the export is checked on, and the largest difference from ``predict``
#: accepted, relative to each joint's largest effort (`onnx_export.relative_difference`).
CHECK_SAMPLES = 1000
TOLERANCE = 1e-6


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident export``."""
    parser = subparsers.add_parser(
        'export', help='write a saved network as an ONNX model (for C++ controllers)',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('model', type=Path, metavar='MODEL', help='model file (.npz)')
    parser.add_argument('--out', type=Path, default=None,
                        help='ONNX file to write (default: MODEL with the suffix .onnx)')
    parser.add_argument('--urdf', type=Path, default=None, metavar='ROBOT.urdf',
                        help='write a physical or hybrid model\'s identified parameters as '
                             'this URDF (instead of ONNX)')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Export, check with ONNX Runtime, print one summary line and the check."""
    from scara_ident_ros.nn import FeedForwardNet
    from scara_ident_ros.nn.onnx_export import (INPUT_NAME, OUTPUT_NAME, network_to_onnx,
                                                onnx_agreement, save_onnx)
    from scara_ident_ros.cli.evaluation import load_model

    network = load_model(args.model)
    if args.urdf is not None:
        return _export_urdf(args, network)
    out: Path = args.out if args.out is not None else args.model.with_suffix('.onnx')
    if not isinstance(network, FeedForwardNet):  # a physical or hybrid model: Pinocchio's
        raise CliError(f'{args.model}: a {type(network).__name__}, not a network: export '
                       'writes the networks (FFS, FFW, FFMW) as ONNX; --urdf writes a '
                       'physical model')
    if out.resolve() == args.model.resolve():
        raise CliError(f'--out {out} is the model file itself; give another name')
    problem = unwritable_file(out)
    if problem:
        raise CliError(f'--out {out} {problem}')
    method = network.method
    names = network.joint_names
    try:
        model = network_to_onnx(network, method=method, joint_names=names)
    except ValueError as exc:
        raise CliError(f'{args.model}: {exc}') from None
    rng = np.random.default_rng(0)
    X = rng.uniform(network.x_scaling.lo, network.x_scaling.hi,
                    (CHECK_SAMPLES, network.n_inputs))
    worst = float(np.max(onnx_agreement(model, network, X)))
    if not worst <= TOLERANCE:  # before writing: a controller must never get a wrong model
        raise CliError(f'{args.model}: ONNX Runtime differs from predict by {worst:.1e} of '
                       f'the largest effort (more than {TOLERANCE:g}); {out} not written')
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        save_onnx(model, out)
    except OSError as exc:
        raise CliError(f'--out {out} cannot be written: {exc.strerror or exc}') from None

    n = network.n_outputs
    joints = ', '.join(names) if names is not None else 'not recorded in the model'
    print(f'{out}: {method.upper()} {network.n_inputs}-{network.n_hidden}-{n}, input '
          f"'{INPUT_NAME}' (batch, {network.n_inputs}) float64 [q, qd, qdd], output "
          f"'{OUTPUT_NAME}' (batch, {n}) float64; joints: {joints}")
    print(f'checked with ONNX Runtime on {CHECK_SAMPLES} random inputs within the input '
          f'ranges: largest difference from predict {worst:.1e} of the largest effort '
          '(per joint)')
    return 0


def _export_urdf(args: argparse.Namespace, loaded: object) -> int:
    """``--urdf``: write, check with Pinocchio's rnea, print one summary line."""
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.dynamics.urdf_export import model_to_urdf
    from scara_ident_ros.errors import ScaraIdentError

    physical = getattr(loaded, 'base', loaded)  # a hybrid's physical (or linear) part
    if not isinstance(physical, PhysicalModel):  # a joint choice's physical candidate
        try:
            physical = getattr(loaded, 'physical', None)
        except TypeError:
            physical = None
    if not isinstance(physical, PhysicalModel):
        raise CliError(f'{args.model}: a {type(loaded).__name__} without a physical model of a '
                       'URDF: --urdf writes identified physical parameters')
    out: Path = args.urdf
    if out.resolve() == args.model.resolve():
        raise CliError(f'--urdf {out} is the model file itself; give another name')
    problem = unwritable_file(out)
    if problem:
        raise CliError(f'--urdf {out} {problem}')
    physical, kept = _with_priors(physical)
    try:
        standard = physical.consistent_standard()
    except ScaraIdentError as exc:
        raise CliError(str(exc)) from None
    text = model_to_urdf(physical, standard)
    worst = _urdf_difference(text, physical, standard)
    if not worst <= TOLERANCE:
        raise CliError(f'{args.model}: Pinocchio\'s rnea of the URDF differs from the model by '
                       f'{worst:.1e} of the largest effort; {out} not written')
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding='utf-8')
    except OSError as exc:
        raise CliError(f'--urdf {out} cannot be written: {exc.strerror or exc}') from None
    print(f'{out}: {physical.n_bodies} links\' inertials and {physical.n_joints} joints\' '
          f'friction ({", ".join(physical.joint_names)}); checked with Pinocchio on '
          f'{CHECK_SAMPLES} random states: largest difference {worst:.1e} of the largest '
          'rigid-body effort')
    if kept:
        print(f'not determined by the training data, kept at the URDF\'s values: '
              f'{", ".join(kept)}')
    return 0


def _with_priors(physical: PhysicalModel) -> tuple[PhysicalModel, tuple[str, ...]]:
    """The model with each parameter its training data did not determine set to its prior
    (:meth:`PhysicalModel.urdf_parameters`), and those parameters' names."""
    from scara_ident_ros.dynamics.physical_model import PhysicalModel

    found = physical.uncertainty
    if found is None or not np.any(found.undetermined):
        return physical, ()
    prior = PhysicalModel.from_arrays(physical.to_arrays(), source=physical.source)
    prior.set_theta(np.where(found.undetermined, physical.urdf_parameters(), physical.theta))
    return prior, found.undetermined_names


def _urdf_difference(text: str, physical: PhysicalModel, standard: np.ndarray) -> float:
    """Largest |rnea(URDF) − model| over random states, relative to the largest effort."""
    import pinocchio as pin

    from scara_ident_ros.dynamics.urdf_export import rigid_body_effort
    full = pin.buildModelFromXML(text)
    names = physical.joint_names
    lock = [full.getJointId(name) for name in list(full.names)[1:]
            if name not in names and full.joints[full.getJointId(name)].nv > 0]
    model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    data = model.createData()
    rng = np.random.default_rng(0)
    n = physical.n_joints
    q = rng.uniform(-np.pi, np.pi, (CHECK_SAMPLES, n))
    qd, qdd = rng.normal(0.0, 1.0, (2, CHECK_SAMPLES, n))
    expected = rigid_body_effort(physical, standard, q, qd, qdd)
    order = [model.joints[model.getJointId(name)] for name in names]
    got = np.zeros_like(expected)
    for k in range(CHECK_SAMPLES):
        qp, vp, ap = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv)
        for j, joint in enumerate(order):
            if joint.nq == 2:
                qp[joint.idx_q:joint.idx_q + 2] = np.cos(q[k, j]), np.sin(q[k, j])
            else:
                qp[joint.idx_q] = q[k, j]
            vp[joint.idx_v], ap[joint.idx_v] = qd[k, j], qdd[k, j]
        tau = pin.rnea(model, data, qp, vp, ap)
        got[k] = [tau[joint.idx_v] for joint in order]
    scale = np.maximum(np.max(np.abs(expected), axis=0), 1e-12)
    return float(np.max(np.abs(got - expected) / scale))
