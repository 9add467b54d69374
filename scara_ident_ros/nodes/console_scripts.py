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
import os
import signal
import sys
from collections.abc import Callable
from functools import partial

__all__ = ['NODES', 'run']

#: The nodes, each a module of ``scara_ident_ros.nodes`` with a ``main()``.
NODES = ('scara_sim', 'robot_sim', 'identifier', 'recorder', 'player', 'excitation')


def run(name: str) -> None:
    """Import node ``name``'s module and run its ``main``; a Ctrl-C before the node handles
    it ends the process with one line on stderr.

    During the imports SIGINT ends the process at once rather than raising
    ``KeyboardInterrupt``: raised inside a C extension's import (numpy's, importing
    ``datetime``), it would come out as an ``ImportError`` with its traceback. Nothing is
    running yet that an immediate exit could lose.
    """
    line = f'{name}: stopped while starting'

    def stopped(*_: object) -> None:
        print(line, file=sys.stderr, flush=True)
        os._exit(0)

    handler = signal.getsignal(signal.SIGINT)
    if handler is signal.default_int_handler:  # not where SIGINT is ignored
        signal.signal(signal.SIGINT, stopped)
    module = importlib.import_module(f'scara_ident_ros.nodes.{name}')
    signal.signal(signal.SIGINT, handler)
    try:
        module.main()
    except KeyboardInterrupt:  # before the node handles it; learners may have started
        print(line, file=sys.stderr)
        sys.exit(0)



def __getattr__(name: str) -> Callable[[], None]:
    """The console script of node ``name`` (``from ...console_scripts import identifier``,
    as the generated scripts do)."""
    if name in NODES:
        return partial(run, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
