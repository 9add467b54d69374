"""``scara-ident recover BAG``: make a bag left by a killed recorder readable again.

The recorder writes and flushes an MCAP chunk at least every second (``max_chunk_size``,
``max_chunk_duration``), so a recorder killed hard (SIGKILL, power loss) leaves a
``.mcap`` file without its summary section and often no ``metadata.yaml``. This command
keeps every complete chunk, rewrites each damaged file (the original is kept as
``<name>.mcap.damaged`` unless ``--no-keep``) and writes a new ``metadata.yaml``; the
bag then opens with rosbags, ``mcap`` and ``scara-ident play``/``train``.

``scara-ident recover BAG --exact-cdr COPY`` repairs the other way a bag can be unreadable:
bags recorded by earlier versions of this package hold ``identified_torque`` and
``external_torque`` messages with 8 bytes past their data, which rosbags refuses (``CDR
message size mismatch``). It writes COPY, a copy of the bag with every message cut to its
exact CDR length and everything else as it was (metadata, QoS, times); BAG is not touched.
A bag that is also damaged is recovered first: run without ``--exact-cdr``, then with it.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from scara_ident_ros.bag import recover_bag, trim_bag

__all__ = ['add_parser', 'run']


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident recover``."""
    parser = subparsers.add_parser(
        'recover', help='rebuild a bag left behind by a killed recorder, or copy an old bag '
                        'with its messages cut to their exact CDR length (--exact-cdr)',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bag', type=Path, help='bag directory or .mcap file')
    parser.add_argument('--no-keep', dest='keep', action='store_false',
                        help='delete the damaged originals instead of keeping them')
    parser.add_argument('--exact-cdr', type=Path, metavar='COPY', default=None,
                        help='write a copy of the bag at COPY (a new path) with every message '
                             'cut to its exact CDR length, so rosbags reads it; the bag itself '
                             'is not changed')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Recover the bag (or copy it cut to exact lengths) and print what was done."""
    if args.exact_cdr is not None:
        print(trim_bag(args.bag, args.exact_cdr).summary())
    else:
        print(recover_bag(args.bag, keep_damaged=args.keep).summary())
    return 0
