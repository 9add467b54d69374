"""Joint states from tables: NumPy ``.npz`` archives and CSV files with named columns.

What is read (all arrays samples × joints, SI units: rad or m, /s, /s², N·m or N):

- ``.npz`` with arrays ``q``, ``tau`` (or ``effort``), optional ``qd``, ``qdd``, ``t`` (s, (N,))
  and ``names`` ((n,) strings). Without ``t`` the rows are samples without time: they need
  ``qd`` and ``qdd``.
- ``.npz`` with a published split, ``X_<split>`` = [q, q', q''] ((N, 3n)) and ``Y_<split>``
  = efforts ((N, n)), like the Barrett WAM's ``X_train``/``Y_test``: samples without time,
  named ``FILE.npz:<split>`` (``wam.npz:train``). Plain ``X``/``Y`` are the split ``''``.
- CSV with a header: a time column (``t``, ``time``, ``stamp``; seconds) and one column per
  joint and quantity, named ``q_<joint>``, ``qd_<joint>``, ``qdd_<joint>``, ``tau_<joint>``
  or ``<joint>_position``, ``_velocity``, ``_acceleration``, ``_effort`` (a leading ``- ``, as
  in ``rostopic echo -p`` / PlotJuggler exports of /joint_states, is dropped). The three files
  of such an export (``..._position.csv``, ``..._velocity.csv``, ``..._effort.csv``, one
  quantity each, on the same stamps) are read together: give the folder or any one of them.

:func:`read_table` returns a :class:`TableData`; :mod:`scara_ident_ros.bag.recording_file`
turns it into the series every command reads.
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.bag.errors import BagError

__all__ = ['FIELDS', 'TableData', 'csv_files', 'read_table']

#: The quantities of a table, in this order: q, q', q'', effort.
FIELDS = ('position', 'velocity', 'acceleration', 'effort')
_NPZ_KEYS = {'position': ('q', 'position'), 'velocity': ('qd', 'velocity', 'dq'),
             'acceleration': ('qdd', 'acceleration', 'ddq'),
             'effort': ('tau', 'effort', 'torque')}
_PREFIXES = {'q': 'position', 'qd': 'velocity', 'dq': 'velocity', 'qdd': 'acceleration',
             'ddq': 'acceleration', 'tau': 'effort', 'effort': 'effort'}
_SUFFIXES = {'position': 'position', 'velocity': 'velocity', 'acceleration': 'acceleration',
             'effort': 'effort'}
_TIME_COLUMNS = ('t', 'time', 'stamp', 'timestamp', '%time', 'time_s')
_EXPORT = re.compile(r'(position|velocity|effort)', re.IGNORECASE)


@dataclass(frozen=True)
class TableData:
    """A table's joint states.

    Attributes
    ----------
    names : tuple of str of length n
    time_s : ndarray of shape (N,) or None
        Sample times (s); None for samples without time.
    values : dict of str to ndarray of shape (N, n)
        The quantities of :data:`FIELDS` the table has.
    """

    names: tuple[str, ...]
    time_s: NDArray[np.float64] | None
    values: dict[str, NDArray[np.float64]]


def read_table(path: Path, split: str | None = None) -> TableData:
    """Read an ``.npz`` or CSV table (a file, or a folder of CSV files).

    Raises
    ------
    BagError
        If the file cannot be read, or its arrays or columns are not the ones above.
    """
    if path.suffix == '.npz':
        return _read_npz(path, split)
    if split is not None:
        raise BagError(f'{path}: a CSV table has no splits (got :{split})')
    return _read_csv(csv_files(path))


def csv_files(path: Path) -> list[Path]:
    """The CSV files read for ``path``: the file and, for one file of a /joint_states export
    (``*position*``, ``*velocity*``, ``*effort*``), its siblings; every ``.csv`` of a folder."""
    if path.is_dir():
        files = sorted(path.glob('*.csv'))
        if not files:
            raise BagError(f'{path}: no .csv file in the folder')
        return files
    match = _EXPORT.search(path.name)
    if match is None:
        return [path]
    siblings = [path.with_name(_EXPORT.sub(kind, path.name, count=1))
                for kind in ('position', 'velocity', 'effort')]
    return [path, *(p for p in siblings if p.is_file() and p != path)]


def _read_npz(path: Path, split: str | None) -> TableData:
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {key: archive[key] for key in archive.files}
    except (OSError, ValueError, EOFError) as exc:
        raise BagError(f'{path}: cannot read the .npz archive ({exc})') from None
    splits = sorted(key[2:] for key in arrays if key.startswith('X_') and f'Y_{key[2:]}'
                    in arrays)
    if split is not None or not any(key in arrays for key in _NPZ_KEYS['position']):
        if 'X' in arrays and 'Y' in arrays:
            splits.append('')
        if split is None:
            if len(splits) == 1:
                split = splits[0]
            else:
                named = ', '.join(f'{path}:{name}' for name in splits if name)
                raise BagError(f'{path}: needs arrays q and tau (and qd, qdd, t, names)'
                               + (f', or a split named: {named}' if named else
                                  f'; it has {", ".join(sorted(arrays)) or "none"}'))
        if split not in splits:
            raise BagError(f'{path}: no split {split!r} (X_{split} and Y_{split}); it has '
                           f'{", ".join(repr(s) for s in splits) or "none"}')
        X = _matrix(path, arrays, f'X_{split}' if split else 'X')
        Y = _matrix(path, arrays, f'Y_{split}' if split else 'Y')
        n = Y.shape[1]
        if X.shape != (Y.shape[0], 3 * n):
            raise BagError(f'{path}: X{"_" + split if split else ""} has shape {X.shape}; '
                           f'need [q, qd, qdd] of the {n} joints of Y: ({Y.shape[0]}, {3 * n})')
        values = {'position': X[:, :n], 'velocity': X[:, n:2 * n],
                  'acceleration': X[:, 2 * n:], 'effort': Y}
        return TableData(_names(path, arrays, n), None, values)
    values = {}
    for field, keys in _NPZ_KEYS.items():
        key = next((k for k in keys if k in arrays), None)
        if key is not None:
            values[field] = _matrix(path, arrays, key)
    if 'effort' not in values:
        raise BagError(f'{path}: no effort array (tau or effort) beside q')
    shape = values['position'].shape
    if any(v.shape != shape for v in values.values()):
        raise BagError(f'{path}: arrays of different shapes: '
                       + ', '.join(f'{k} {v.shape}' for k, v in values.items()))
    time_s = None
    if 't' in arrays:
        time_s = np.asarray(arrays['t'], dtype=np.float64).reshape(-1)
        if time_s.shape[0] != shape[0]:
            raise BagError(f'{path}: t has {time_s.shape[0]} samples, q has {shape[0]}')
    return TableData(_names(path, arrays, shape[1]), time_s, values)


def _matrix(path: Path, arrays: dict[str, np.ndarray], key: str) -> NDArray[np.float64]:
    value = np.asarray(arrays[key])
    if value.ndim == 1:
        value = value[:, None]
    if value.ndim != 2 or not np.issubdtype(value.dtype, np.number):
        raise BagError(f'{path}: {key} is not a numeric samples x joints array '
                       f'({value.dtype}, shape {value.shape})')
    return value.astype(np.float64)


def _names(path: Path, arrays: dict[str, np.ndarray], n: int) -> tuple[str, ...]:
    if 'names' not in arrays:
        return tuple(f'joint{j + 1}' for j in range(n))
    names = tuple(str(name) for name in np.asarray(arrays['names']).reshape(-1))
    if len(names) != n or len(set(names)) != n:
        raise BagError(f'{path}: names {list(names)} are not {n} distinct joint names')
    return names


def _column(name: str) -> tuple[str, str] | None:
    """(field, joint) of a CSV column name, or None."""
    name = name.strip()
    if name.startswith('- '):
        name = name[2:].strip()
    head, _, tail = name.partition('_')
    if tail and head.lower() in _PREFIXES:
        return _PREFIXES[head.lower()], tail
    stem, _, suffix = name.rpartition('_')
    if stem and suffix.lower() in _SUFFIXES:
        return _SUFFIXES[suffix.lower()], stem
    return None


def _read_csv(files: list[Path]) -> TableData:
    time_s: NDArray[np.float64] | None = None
    columns: dict[str, dict[str, NDArray[np.float64]]] = {field: {} for field in FIELDS}
    names: list[str] = []
    first = files[0]
    for file in files:
        try:
            with file.open(newline='') as stream:
                header = next(csv.reader(stream), None)
            data = np.loadtxt(file, delimiter=',', skiprows=1, ndmin=2)
        except (OSError, ValueError, UnicodeDecodeError) as exc:
            raise BagError(f'{file}: cannot read as a CSV table of numbers '
                           f'({" ".join(str(exc).split())})') from None
        if not header or data.shape[1] != len(header):
            raise BagError(f'{file}: the header does not name the {data.shape[1]} columns')
        lower = [h.strip().lower() for h in header]
        clock = next((lower.index(c) for c in _TIME_COLUMNS if c in lower), None)
        if clock is not None:
            stamps = data[:, clock]
            if time_s is None:
                time_s = stamps
            elif stamps.shape != time_s.shape or not np.array_equal(stamps, time_s):
                raise BagError(f'{file}: its time column differs from that of {first}; the '
                               'files of one export must share their stamps')
        for index, label in enumerate(header):
            if index == clock:
                continue
            parsed = _column(label)
            if parsed is None:
                raise BagError(f'{file}: column {label!r} names no joint quantity (use '
                               'q_<joint>, qd_, qdd_, tau_ or <joint>_position, _velocity, '
                               '_acceleration, _effort, and t in s)')
            field, joint = parsed
            columns[field][joint] = data[:, index]
            if joint not in names:
                names.append(joint)
    values = {}
    for field, by_joint in columns.items():
        if not by_joint:
            continue
        if missing := [joint for joint in names if joint not in by_joint]:
            raise BagError(f'{first}: no {field} column for {", ".join(missing)}')
        values[field] = np.column_stack([by_joint[joint] for joint in names])
    if 'position' not in values or 'effort' not in values:
        lacking = ' and '.join(f for f in ('position', 'effort') if f not in values)
        raise BagError(f'{first}: no {lacking} columns (read {", ".join(map(str, files))})')
    return TableData(tuple(names), time_s, values)
