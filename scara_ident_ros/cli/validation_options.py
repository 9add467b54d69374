"""The validation split's options, one definition for ``train`` and ``tables``.

Both commands validate on the same split
(:func:`~scara_ident_ros.identification.split.block_split`), so they take the same two
options with the same defaults and checks.
"""
from __future__ import annotations

import argparse

from scara_ident_ros.cli import CliError
from scara_ident_ros.identification.split import VALIDATION_BLOCK_S, VALIDATION_FRACTION

__all__ = ['add_validation_options', 'check_validation_options']


def add_validation_options(parser: argparse.ArgumentParser, *, zero: str = '') -> None:
    """Add ``--validation-fraction`` and ``--validation-block``; ``zero`` says what a
    fraction of 0 means for the command ('' when nothing particular)."""
    zero_note = f'; 0: {zero}' if zero else ''
    parser.add_argument('--validation-fraction', type=float, default=VALIDATION_FRACTION,
                        help="fraction of the run's time blocks kept out of training, one "
                             'block drawn from each stretch of 1/fraction blocks '
                             f'(default: {VALIDATION_FRACTION:g}{zero_note})')
    parser.add_argument('--validation-block', type=float, default=VALIDATION_BLOCK_S,
                        metavar='SECONDS',
                        help=f'length of the time blocks (default: {VALIDATION_BLOCK_S:g} s)')


def check_validation_options(args: argparse.Namespace) -> None:
    """Raise :class:`CliError` (one line, exit 2) for a fraction outside [0, 1) or a block
    that is not positive."""
    if not 0.0 <= args.validation_fraction < 1.0:
        raise CliError(f'--validation-fraction must be in [0, 1), got '
                       f'{args.validation_fraction}')
    if not args.validation_block > 0.0:
        raise CliError(f'--validation-block must be positive, got {args.validation_block}')
