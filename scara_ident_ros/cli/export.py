"""``scara-ident export MODEL.npz --out MODEL.onnx``: a saved network as an ONNX model.

Writes the network, scaling included, as a float64 ONNX model that ONNX Runtime (C++,
Python, ...) runs without this package: input ``x`` of shape (batch, 3n) holding the joint
positions, velocities and accelerations [q, q', q''] in SI units (rad, m, /s, /s²), output
``effort`` of shape (batch, n) in N·m or N. The model's metadata records the joint names
(comma-separated, when the .npz has them), the method and the package version.

Before writing, runs the ONNX model with ONNX Runtime on inputs drawn within the network's
input ranges (the joint limits of a model scaled from them) and refuses to write it if it
is further than 1e-6 (relative) from the package's own prediction. docs/onnx_export.md
shows how a ros2_control controller loads it.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from scara_ident_ros.cli import CliError
from scara_ident_ros.paths import unwritable_file

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
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Export, check with ONNX Runtime, print one summary line and the check."""
    from scara_ident_ros.nn import FeedForwardNet
    from scara_ident_ros.nn.onnx_export import (INPUT_NAME, OUTPUT_NAME, network_to_onnx,
                                                onnx_agreement, save_onnx)
    from scara_ident_ros.cli.evaluation import load_model

    out: Path = args.out if args.out is not None else args.model.with_suffix('.onnx')
    network = load_model(args.model)
    if not isinstance(network, FeedForwardNet):  # a physical or hybrid model: Pinocchio's
        raise CliError(f'{args.model}: a {type(network).__name__}, not a network: export '
                       'writes the networks (FFS, FFW, FFMW) only')
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
