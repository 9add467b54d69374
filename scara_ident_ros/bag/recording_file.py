"""One reader of recordings, whatever their file: the joint-state series every command uses.

``scara-ident train``, ``evaluate``, ``tables`` and ``play`` read their RECORDING argument
with :func:`read_recording`:

- a rosbag2 bag (MCAP or sqlite3 directory, a bare ``.mcap`` or ``.db3``):
  :func:`~scara_ident_ros.bag.read_joint_states`;
- a ROS 1 bag (``.bag``): :func:`~scara_ident_ros.bag.ros1_bag.read_ros1_joint_states`;
- a table (``.npz``, ``.csv``, or a folder of CSV files such as a /joint_states export):
  :func:`~scara_ident_ros.bag.table_file.read_table`. A table with a published split is
  named ``FILE.npz:SPLIT`` (``barrett_wam.npz:train``, ``barrett_wam.npz:test``).

Tables may lack what bags always have: a table without time (the WAM's) gets stamps
:data:`TIMELESS_PERIOD_S` apart in row order (``timed`` False) and must give q' and q''
itself; a recording without velocities (the TX40's) gets them from its positions
(:func:`~scara_ident_ros.identification.derived_velocity.derive_velocity`,
``velocity_derived``); a table's q'' (``acceleration``) is used as given.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.joint_state_series import JointStateSeries

__all__ = ['KINDS', 'TIMELESS_PERIOD_S', 'RecordingSeries', 'is_rosbag2', 'read_recording',
           'recording_kind', 'split_name']

#: Time between two rows of a table without time (s): their stamps are only an order.
TIMELESS_PERIOD_S = 0.001
#: What :func:`recording_kind` returns.
KINDS = ('rosbag2', 'ros1', 'npz', 'csv')
_TABLE_TOPIC = '(table)'


@dataclass(frozen=True, kw_only=True)
class RecordingSeries(JointStateSeries):
    """Joint states of a recording, one row per sample, in the order of the file.

    The arrays and names of a :class:`~scara_ident_ros.bag.joint_state_series.JointStateSeries`
    (``topic`` is ``'(table)'`` or ``'(table):split'`` for a table; a table without time has
    ``stamp_ns`` and ``log_time_ns`` row order times :data:`TIMELESS_PERIOD_S`), and what
    they came from (keyword-only):

    Attributes
    ----------
    path : Path
        The file or folder (without a ``:split``).
    kind : str
        One of :data:`KINDS`.
    acceleration : ndarray of shape (N, n) or None
        q'' as the table gives it; None: to be estimated from q'.
    timed : bool
        False for a table without time.
    velocity_derived : tuple of str
        Joints whose q' was derived from q.
    """

    path: Path
    kind: str
    acceleration: NDArray[np.float64] | None = None
    timed: bool = True
    velocity_derived: tuple[str, ...] = ()

    def select(self, joints: Sequence[str]) -> RecordingSeries:
        """The series of ``joints`` only, in that order.

        Raises
        ------
        BagError
            If a joint is not in the recording (the message names them and those it has).
        """
        if missing := [name for name in joints if name not in self.names]:
            raise BagError(f'{self.path}: no joint {", ".join(missing)} in the recording '
                           f'(its joints: {", ".join(self.names)})')
        index = [self.names.index(name) for name in joints]
        return replace(self, names=tuple(joints), position=self.position[:, index],
                       velocity=self.velocity[:, index], effort=self.effort[:, index],
                       acceleration=None if self.acceleration is None
                       else self.acceleration[:, index],
                       velocity_derived=tuple(n for n in self.velocity_derived if n in joints))


def split_name(path: str | Path) -> tuple[Path, str | None]:
    """``'wam.npz:train'`` -> (Path('wam.npz'), 'train'); a path without a split -> (path,
    None). A path that exists as given is never split."""
    text = str(path)
    if Path(text).exists() or ':' not in text:
        return Path(text), None
    head, _, split = text.rpartition(':')
    if head.endswith('.npz'):
        return Path(head), split
    return Path(text), None


def recording_kind(path: Path) -> str:
    """Which reader reads ``path`` (:data:`KINDS`).

    Raises
    ------
    BagError
        If the path does not exist or is no kind of recording.
    """
    if not path.exists():
        raise BagError(f'{path}: does not exist')
    if path.is_dir():
        if (path / 'metadata.yaml').is_file() or any(path.glob('*.mcap')) or any(
                path.glob('*.db3')):
            return 'rosbag2'
        if any(path.glob('*.csv')):
            return 'csv'
        raise BagError(f'{path}: neither a rosbag2 bag (metadata.yaml, .mcap, .db3) nor a '
                       'folder of CSV files')
    suffix = path.suffix.lower()
    if suffix in ('.mcap', '.db3'):
        return 'rosbag2'
    if suffix == '.bag':
        return 'ros1'
    if suffix in ('.npz', '.csv'):
        return suffix[1:]
    raise BagError(f'{path}: not a recording (expected a rosbag2 bag, a .mcap, .db3 or ROS 1 '
                   '.bag file, an .npz or .csv table, or a folder of CSV files)')


def is_rosbag2(path: str | Path) -> bool:
    """Whether ``path`` is a rosbag2 bag (the one kind with topics besides joint states,
    e.g. a run's identifier outputs); False for anything else, readable or not."""
    file, split = split_name(path)
    try:
        return split is None and recording_kind(file) == 'rosbag2'
    except BagError:
        return False


def read_recording(path: str | Path, *, topic: str | None = None,
                   joints: Sequence[str] | None = None, derive: bool = True
                   ) -> RecordingSeries:
    """Read any recording's joint states (module docstring).

    Parameters
    ----------
    path : str or Path
        The recording; ``FILE.npz:SPLIT`` names a split.
    topic : str, optional
        The JointState topic of a bag (default: the only one, or /joint_states); a table
        has none and refuses one.
    joints : sequence of str, optional
        The joints to read, in this order (default: all, in the recording's order).
    derive : bool
        Derive q' from q for the joints that have none.

    Raises
    ------
    BagError
        If the recording cannot be read, is of no known kind, or lacks a joint of
        ``joints``.
    """
    file, split = split_name(path)
    kind = recording_kind(file)
    if split is not None and kind != 'npz':
        raise BagError(f'{path}: only an .npz table has splits')
    if kind in ('rosbag2', 'ros1'):
        if kind == 'rosbag2':
            from scara_ident_ros.bag.joint_states import read_joint_states
            bag = read_joint_states(file, topic=topic, joints=list(joints) if joints else None)
        else:
            from scara_ident_ros.bag.ros1_bag import read_ros1_joint_states
            bag = read_ros1_joint_states(file, topic=topic, joints=joints)
        series = RecordingSeries(bag.topic, bag.names, bag.stamp_ns, bag.log_time_ns,
                                 bag.position, bag.velocity, bag.effort, path=file, kind=kind)
    else:
        if topic is not None:
            raise BagError(f'{file}: a table has no topics (got --topic {topic})')
        series = _table_series(file, kind, split)
        if joints:
            series = series.select(joints)
    return _with_velocity(series) if derive else series


def _table_series(path: Path, kind: str, split: str | None) -> RecordingSeries:
    from scara_ident_ros.bag.table_file import read_table

    table = read_table(path, split)
    count, n = table.values['position'].shape
    if count < 2:
        raise BagError(f'{path}: {count} sample(s); need at least 2')
    timed = table.time_s is not None
    if table.time_s is not None:
        stamps = np.round(np.asarray(table.time_s) * 1e9).astype(np.int64)
        if not np.isfinite(table.time_s).all():
            raise BagError(f'{path}: the time column has non-finite values')
    else:
        lacking = [f for f in ('velocity', 'acceleration') if f not in table.values]
        if lacking:
            raise BagError(f'{path}: a table without time (no t) needs q\' and q\'\' '
                           f'as given; it has no {" and no ".join(lacking)}')
        stamps = np.arange(count, dtype=np.int64) * round(TIMELESS_PERIOD_S * 1e9)
    nan = np.full((count, n), np.nan)
    label = _TABLE_TOPIC + (f':{split}' if split else '')
    return RecordingSeries(label, table.names, stamps, stamps.copy(), table.values['position'],
                           table.values.get('velocity', nan), table.values['effort'],
                           path=path, kind=kind, acceleration=table.values.get('acceleration'),
                           timed=timed)


def _with_velocity(series: RecordingSeries) -> RecordingSeries:
    """Derive q' from q for the joints whose velocity column is all NaN."""
    from scara_ident_ros.identification.centred_differentiator import recording_window
    from scara_ident_ros.identification.derived_velocity import derive_velocity

    absent = np.asarray(np.isnan(series.velocity).all(axis=0)
                        & ~np.isnan(series.position).all(axis=0), dtype=bool)
    if not absent.any() or not series.timed:
        return series
    order = np.argsort(series.stamp_ns, kind='stable')
    velocity = series.velocity.copy()
    derived = np.empty((len(series), int(absent.sum())))
    derived[order] = derive_velocity(series.stamp_ns[order], series.position[order][:, absent],
                                     effort=series.effort[order],
                                     window=recording_window(series.stamp_ns))
    velocity[:, absent] = derived
    names = tuple(name for j, name in enumerate(series.names) if bool(absent[j]))
    return replace(series, velocity=velocity, velocity_derived=names)
