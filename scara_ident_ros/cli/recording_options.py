"""What the commands that read a recording say about it: its help text and its summary line.

``train``, ``evaluate``, ``tables`` and ``play`` take any recording
:func:`~scara_ident_ros.bag.recording_file.read_recording` reads.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ['RECORDING_HELP', 'add_span_option', 'cut_span', 'parse_span', 'recording_note',
           'urdf_joints_not_recorded']

RECORDING_HELP = ('the recording: a rosbag2 bag (directory, .mcap or .db3), a ROS 1 .bag, an '
                  '.npz table (q, qd, qdd, tau, t, names; or X_<split>/Y_<split> named '
                  'FILE.npz:SPLIT), a CSV table with named columns, or a /joint_states CSV '
                  'export (its folder or one of its files)')


def parse_span(text: str) -> tuple[float, float]:
    """``'0:0.7'`` → (0.0, 0.7): a part of a recording's time, as fractions 0 ≤ a < b ≤ 1
    (argparse type: ``ArgumentTypeError`` otherwise)."""
    import argparse

    try:
        start, end = (float(part) for part in text.split(':'))
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not START:END') from None
    if not 0.0 <= start < end <= 1.0:
        raise argparse.ArgumentTypeError(f'{text}: need 0 <= START < END <= 1')
    return start, end


def add_span_option(parser: Any) -> None:
    """Add ``--span START:END`` (``train`` and ``evaluate``: the same part of a recording
    to learn from and to score on)."""
    parser.add_argument('--span', type=parse_span, default=None, metavar='START:END',
                        help='use only this part of the recording\'s time, as fractions: '
                             '0:0.7 its first 70 %%, 0.7:1 the rest (default: all)')


def cut_span(data: Any, span: tuple[float, float]) -> Any:
    """The samples of ``data`` (a :class:`~scara_ident_ros.identification.dataset.Dataset`)
    stamped in the ``span`` (start, end) fractions of its time: [start, end), the end
    included when it is 1. The samples are built from the whole recording first, so q'' at
    the cut uses the samples beyond it, as it would online."""
    stamps = np.asarray(data.stamp_ns)
    if not stamps.shape[0]:
        return data
    first, span_ns = int(stamps[0]), int(stamps[-1] - stamps[0])
    low = first + round(span[0] * span_ns)
    high = first + round(span[1] * span_ns)
    mask = (stamps >= low) & ((stamps < high) | (span[1] >= 1.0))
    return data.take(mask, data.name)


def recording_note(recording: Any) -> str:
    """The recording's rate, gaps and what the reader made up, for the summary line, e.g.
    ``'; 5000 Hz (median step); q\\' derived from q for joint_1, joint_2'``.

    ``recording`` is an :class:`~scara_ident_ros.identification.recording.Recording`.
    """
    series = recording.series
    notes = []
    steps = np.diff(np.sort(np.asarray(series.stamp_ns)))
    steps = steps[steps > 0]
    if getattr(series, 'timed', True) and steps.size:
        median = float(np.median(steps))
        notes.append(f'{1e9 / median:.4g} Hz (median step; steps {steps.min() * 1e-6:.3g}-'
                     f'{steps.max() * 1e-6:.3g} ms)')
    gaps = getattr(recording.samples, 'gaps', 0)
    if gaps:
        notes.append(f'{gaps} gap{"s" if gaps > 1 else ""} (q\'\' restarted)')
    if not getattr(series, 'timed', True):
        notes.append('rows without time, in order')
    derived = getattr(series, 'velocity_derived', ())
    if derived:
        notes.append(f"q' derived from q for {', '.join(derived)}")
    if getattr(series, 'acceleration', None) is not None:
        notes.append("q'' as given")
    return ''.join(f'; {note}' for note in notes)


def urdf_joints_not_recorded(urdf: Path, names: Sequence[str]) -> list[str]:
    """The moving joints (revolute, continuous, prismatic) of ``urdf`` that are not among the
    recording's ``names``: a physical model holds them fixed at 0 (e.g. a gripper's). An
    unreadable URDF gives [] here (its reader says what is wrong)."""
    import xml.etree.ElementTree as ElementTree

    try:
        root = ElementTree.parse(urdf).getroot()
    except (OSError, ElementTree.ParseError):
        return []
    moving = [joint.get('name', '') for joint in root.iter('joint')
              if joint.get('type') in ('revolute', 'continuous', 'prismatic')
              and joint.find('mimic') is None]
    return [name for name in moving if name not in names]
