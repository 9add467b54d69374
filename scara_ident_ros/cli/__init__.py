"""``scara-ident``: the project's command line, one module per subcommand.

Besides them, what ``train``, ``evaluate`` and ``export`` share: :mod:`.evaluation` (a saved
model checked and scored), :mod:`.progress` (the training progress bar) and
:mod:`.physical_parameters` (a physical model's parameter tables).

Each subcommand module defines ``add_parser(subparsers)`` (registering its
``argparse`` sub-parser, with ``help`` and ``description``) and
``run(args) -> int`` (the exit status). :func:`main` only dispatches.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from scara_ident_ros.errors import ScaraIdentError

__all__ = ['SUBCOMMANDS', 'main']

#: Subcommand name -> module under ``scara_ident_ros.cli``.
SUBCOMMANDS: dict[str, str] = {
    'run': 'run',
    'play': 'play',
    'compare': 'compare',
    'train': 'train',
    'evaluate': 'evaluate',
    'tables': 'tables',
    'recover': 'recover',
    'export': 'export',
    'excitation': 'excitation',
    'lag': 'lag',
}


class CliError(ScaraIdentError):
    """A bad option: printed as one line, exit status 2, no traceback (as every
    :class:`~scara_ident_ros.errors.ScaraIdentError`)."""


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """Return the top-level parser with every subcommand, or only ``only``, registered.

    Running one command imports only that command's module: it starts faster and does
    not depend on the others.
    """
    parser = argparse.ArgumentParser(
        prog='scara-ident',
        description='Online and offline identification of robot inverse dynamics '
                    'with FFMW/FFW/FFS networks (scara_ident_ros).')
    subparsers = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for name, module_name in SUBCOMMANDS.items():
        if only is None or name == only:
            importlib.import_module(f'{__name__}.{module_name}').add_parser(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``scara-ident`` console script."""
    from scara_ident_ros.nodes.rosenv import ensure_local_dds

    ensure_local_dds()
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv[0] if argv and argv[0] in SUBCOMMANDS else None)
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ScaraIdentError as exc:
        print(f'scara-ident {args.command}: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == '__main__':
    sys.exit(main())
