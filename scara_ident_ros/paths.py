"""Can the program write its output there? Asked before the work, not after it.

A command that trains for minutes, or a node that learns for hours, must not find out at
the end that its output path is a directory, under ``/proc`` or read-only: these checks
try what the writer will do (make the folder, create a temporary file in it) and say why
not in a few words, for a one-line error.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ['unwritable_dir', 'unwritable_file']


def unwritable_file(path: str | Path) -> str:
    """Why a file cannot be written at ``path``; '' if it can (see :func:`unwritable_dir`)."""
    target = Path(path)
    if target.is_dir():
        return 'is a directory; give a file name'
    problem = unwritable_dir(target.parent)
    if problem:
        return f'its folder {problem}'
    if target.exists() and not os.access(target, os.W_OK):
        return 'is not writable'
    return ''


def unwritable_dir(path: str | Path) -> str:
    """Why files cannot be written in the folder ``path``; '' if they can.

    Folders the check has to make to find out are removed again: a refused command leaves
    nothing behind.
    """
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        return 'exists and is not a directory'
    made = [p for p in (folder, *folder.parents) if not p.exists()]  # deepest first
    try:
        folder.mkdir(parents=True, exist_ok=True)
        # what an atomic save does: a temporary file in the folder (root ignores modes)
        with tempfile.NamedTemporaryFile(dir=folder, prefix='.write-check.'):
            pass
    except OSError as exc:
        return f'cannot be written: {exc.strerror or exc}'
    finally:
        for created in made:
            try:
                created.rmdir()
            except OSError:
                break
    return ''
