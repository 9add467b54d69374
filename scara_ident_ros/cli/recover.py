"""``scara-ident recover BAG``: make a bag left by a killed recorder readable again.

The recorder writes and flushes an MCAP chunk at least every second (``max_chunk_size``,
``max_chunk_duration``), so a recorder killed hard (SIGKILL, power loss) leaves a
``.mcap`` file without its summary section and often no ``metadata.yaml``. This command
keeps every complete chunk, rewrites each damaged file (the original is kept as
``<name>.mcap.damaged`` unless ``--no-keep``) and writes a new ``metadata.yaml``; the
bag then opens with rosbags, ``mcap`` and ``scara-ident play``/``train``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from scara_ident_ros.bag import recover_bag

__all__ = ['add_parser', 'run']


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident recover``."""
    parser = subparsers.add_parser(
        'recover', help='rebuild a bag left behind by a killed recorder',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bag', type=Path, help='bag directory or .mcap file')
    parser.add_argument('--no-keep', dest='keep', action='store_false',
                        help='delete the damaged originals instead of keeping them')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Recover the bag and print what was kept."""
    print(recover_bag(args.bag, keep_damaged=args.keep).summary())
    return 0
