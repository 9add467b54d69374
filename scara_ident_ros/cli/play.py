"""``scara-ident play RECORDING``: publish a recording again (the ``player`` node, in-process).

A rosbag2 bag is played as recorded; a ROS 1 bag or a table (``.npz``, CSV, a /joint_states
CSV export, ``FILE.npz:SPLIT``) as its joint states on /joint_states, at its own timing.

``scara-ident play run1 --rate 2 --loop --clock --topics /joint_states
--remap /joint_states:=/replay/joint_states`` runs the same node as ``ros2 run
scara_ident_ros player`` with these options as its parameters. The bag is opened first,
so a missing, corrupt or truncated bag is reported on one line (exit status 2) before
anything starts; the command returns 0 when the bag has been played (never with
``--loop``: stop it with Ctrl-C).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from scara_ident_ros.cli import CliError
from scara_ident_ros.cli.recording_options import RECORDING_HELP

__all__ = ['add_parser', 'run']


def add_parser(subparsers: Any) -> None:
    """Register ``play`` and its options."""
    parser = subparsers.add_parser(
        'play', help='publish a recorded bag again, timed as recorded',
        description=__doc__.split('\n\n')[0].replace('``', ''))
    parser.add_argument('bag', type=Path, metavar='RECORDING',
                        help=RECORDING_HELP + '; a ROS 1 bag or a table is played as '
                        '/joint_states, timed by its stamps')
    parser.add_argument('--rate', default='1.0',
                        help="playback speed factor (default 1); 0 or 'max' = as fast as "
                             'possible')
    parser.add_argument('--loop', action='store_true', help='start over at the end, until Ctrl-C')
    parser.add_argument('--clock', action='store_true',
                        help='also publish /clock with the recorded time')
    parser.add_argument('--clock-rate', type=float, default=100.0, metavar='HZ',
                        help='rate of /clock (default 100)')
    parser.add_argument('--topics', nargs='+', default=[], metavar='TOPIC',
                        help='topics or glob patterns to play (default: all)')
    parser.add_argument('--remap', nargs='+', default=[], metavar='OLD:=NEW',
                        help='rename topics on the way out')
    parser.add_argument('--wait-timeout', type=float, default=5.0, metavar='S',
                        help='longest wait for every played topic to have a subscriber '
                             '(default 5)')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Check the options and the bag, then run the player node until the bag is done."""
    from scara_ident_ros.bag import parse_rate, parse_remaps
    from scara_ident_ros.bag.series_source import open_recording_source

    rate = parse_rate(args.rate)  # a bad rate, remapping or bag: one line from cli.main
    parse_remaps(args.remap)
    if args.wait_timeout < 0 or args.clock_rate <= 0:
        raise CliError('--wait-timeout must be >= 0 and --clock-rate > 0')
    with open_recording_source(args.bag):  # a table is read twice: once here to check it
        pass

    from rclpy.parameter import Parameter

    from scara_ident_ros.nodes.player import PlayerNode
    from scara_ident_ros.nodes.runtime import run_node

    overrides = [
        Parameter('bag', value=str(args.bag)),
        Parameter('rate', value=rate),
        Parameter('loop', value=bool(args.loop)),
        Parameter('clock', value=bool(args.clock)),
        Parameter('clock_rate', value=float(args.clock_rate)),
        Parameter('wait_timeout', value=float(args.wait_timeout)),
    ]
    if args.topics:
        overrides.append(Parameter('topics', value=list(args.topics)))
    if args.remap:
        overrides.append(Parameter('remap', value=list(args.remap)))
    return run_node('scara-ident play', lambda: PlayerNode(parameter_overrides=overrides), [])
