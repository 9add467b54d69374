"""The nodes' console scripts (``ros2 run scara_ident_ros NODE``, ``.venv/bin/NODE``).

A node's module imports rclpy, numpy and its core before its ``main`` can handle Ctrl-C:
about a second, more on a busy machine. A SIGINT meanwhile (a terminal's Ctrl-C, a launch
stopping the graph as it starts) would end the process with the import's
``KeyboardInterrupt`` traceback, 30-60 lines. Each entry point here imports its node's
module only inside a handler (:func:`run`; ``console_scripts.identifier`` is
``run('identifier')``) that ends such a start with one line (exit status 0, as a
node stopped while running: :func:`~scara_ident_ros.nodes.runtime.run_node`).
"""
from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from functools import partial

__all__ = ['NODES', 'run']

#: The nodes, each a module of ``scara_ident_ros.nodes`` with a ``main()``.
NODES = ('scara_sim', 'robot_sim', 'identifier', 'recorder', 'player', 'excitation')


def run(name: str) -> None:
    """Import node ``name``'s module and run its ``main``; a Ctrl-C before the node handles
    it ends the process with one line on stderr."""
    try:
        main = importlib.import_module(f'scara_ident_ros.nodes.{name}').main
        main()
    except KeyboardInterrupt:
        print(f'{name}: stopped while starting', file=sys.stderr)
        sys.exit(0)



def __getattr__(name: str) -> Callable[[], None]:
    """The console script of node ``name`` (``from ...console_scripts import identifier``,
    as the generated scripts do)."""
    if name in NODES:
        return partial(run, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
