"""``scara-ident evaluate``: errors of a saved model on the joint states of a recording.

Loads a model written by ``scara-ident train`` (a network, a physical or a hybrid model)
or by an identifier (FeedForwardNet.save), reads the recording's joint states (a bag or a
table, as train reads them: FILE.npz:SPLIT for a published split), maps them to the
model's joints BY NAME (metadata joint_names; a model without names needs a recording with
as many joints, taken in message order), builds the network inputs as the identifier
does (its input stage: q'' from q' by the zero-phase centred estimate, bad samples
dropped; a table's q'' as given) and prints, as a Markdown table, each joint's MSE
((N·m)² or N²) and normalised MSE (MSE / variance of the joint's effort over the evaluated
samples; 1 = no better than the mean effort), and below it the SMSE of all joints (their
squared errors over their squared deviations, 1 − R² variance-weighted: the figure
published for the WAM's split). Typical use: a model trained on one run evaluated on
another (held-out) run. For a physical or hybrid model it then prints the identified base
parameters (beside the URDF's values) and the friction.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from scara_ident_ros.cli.recording_options import (RECORDING_HELP, add_span_option,
                                                    cut_span, recording_note)

__all__ = ['add_parser', 'run']


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident evaluate``."""
    parser = subparsers.add_parser(
        'evaluate', help='per-joint MSE and NMSE of a saved model on a bag',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('model', type=Path, metavar='MODEL', help='model file (.npz)')
    parser.add_argument('bag', type=Path, metavar='RECORDING',
                        help=RECORDING_HELP)
    add_span_option(parser)
    parser.add_argument('--topic', default=None,
                        help='JointState topic (default: the only one, or /joint_states)')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Evaluate and print the table."""
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.cli.evaluation import errors_markdown, evaluate_recording
    from scara_ident_ros.cli.physical_parameters import parameters_markdown
    from scara_ident_ros.identification.recording import skipped_text

    model, recording, stats = evaluate_recording(args.model, args.bag, topic=args.topic,
                                                 span=args.span)
    samples = recording.samples
    data = samples.data if args.span is None else cut_span(samples.data, args.span)
    method = model.method.upper()
    mapping = ('mapped by name' if model.joint_names is not None
               else 'in message order (model has no names)')
    print(f'{method} model {args.model} on {args.bag} {recording.topic}: '
          f'{len(data)} samples over {data.seconds:.1f} s, joints {mapping} '
          f'(skipped: {skipped_text(samples)}{recording_note(recording)})\n')
    print(errors_markdown(samples.names, {args.bag.name or str(args.bag): stats}))
    physical = getattr(model, 'base', model)  # a hybrid's physical (or linear) part
    if isinstance(physical, PhysicalModel):
        print(parameters_markdown(physical))
    return 0
