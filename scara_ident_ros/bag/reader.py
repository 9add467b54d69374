"""Read any rosbag2 bag, or a bare ``.mcap`` file, as raw serialized messages.

:func:`open_bag` accepts a rosbag2 bag directory (``metadata.yaml`` plus MCAP or
sqlite3 storage files, one or several after a split, written by this project or by
anything else) or a single ``.mcap``/``.db3`` file without metadata (e.g. written by
``mcap-ros2-support``). Reading goes through ``rosbags.rosbag2.Reader``; nothing is
deserialized here, the messages come out as the CDR bytes that were recorded::

    with open_bag('run1') as bag:
        print(bag.topics)                    # {'/joint_states': TopicInfo(msgtype, count)}
        for msg in bag.messages(['/joint_states']):
            msg.topic, msg.msgtype, msg.log_time_ns, msg.data

Whatever goes wrong (missing path, not a bag, a truncated or corrupt file, also when
discovered half-way through the messages) is raised as one :class:`BagError` whose
message names the file.
"""
from __future__ import annotations

import shlex
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import TracebackType
from typing import NamedTuple

from rosbags.interfaces import Connection, Qos
from rosbags.rosbag2 import Reader

from scara_ident_ros.bag.errors import BagError

__all__ = ['BagMessage', 'BagSource', 'TopicInfo', 'open_bag']

MCAP_MAGIC = b'\x89MCAP0\r\n'
STORAGE_SUFFIXES = ('.mcap', '.db3')


class TopicInfo(NamedTuple):
    """A topic of a bag: its message type and how many messages it holds."""

    msgtype: str
    # Shadows tuple.count on purpose: callers read info.count and compare TopicInfo with
    # plain (msgtype, count) tuples, so it stays a NamedTuple with this field name.
    count: int  # type: ignore[assignment]


class BagMessage(NamedTuple):
    """One recorded message.

    Attributes
    ----------
    topic : str
    msgtype : str
        E.g. ``'sensor_msgs/msg/JointState'``.
    log_time_ns : int
        When it was recorded (rosbag2: reception time), integer nanoseconds.
    data : bytes
        The serialized CDR message, as received.
    """

    topic: str
    msgtype: str
    log_time_ns: int
    data: bytes


class BagSource:
    """An open bag: topics, time range and messages in log-time order.

    Use :func:`open_bag` to create one; close it with :meth:`close` or a ``with`` block.
    """

    def __init__(self, path: Path, reader: Reader) -> None:
        self.path = path
        self._reader = reader
        self._topics: dict[str, TopicInfo] = {}
        self._qos: dict[str, list[Qos]] = {}
        for connection in reader.connections:
            known = self._topics.get(connection.topic)
            count = connection.msgcount + (known.count if known else 0)
            self._topics[connection.topic] = TopicInfo(connection.msgtype, count)
            self._qos.setdefault(connection.topic, []).extend(
                getattr(connection.ext, 'offered_qos_profiles', []))

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """Topic name -> (message type, message count), sorted by name."""
        return dict(sorted(self._topics.items()))

    @property
    def message_count(self) -> int:
        """Messages in the bag, all topics."""
        return sum(info.count for info in self._topics.values())

    @property
    def start_ns(self) -> int:
        """Log time of the first message, integer ns (0 for an empty bag)."""
        return self._reader.start_time if self.message_count else 0

    @property
    def end_ns(self) -> int:
        """Log time of the last message, integer ns (0 for an empty bag)."""
        return self._reader.end_time - 1 if self.message_count else 0

    def offered_qos(self, topic: str) -> list[Qos]:
        """The QoS profiles the recorded publishers of ``topic`` offered (may be empty)."""
        return list(self._qos.get(topic, []))

    def describe_topics(self) -> str:
        """One line listing the topics, e.g. ``'/a (std_msgs/msg/Float64, 10 msgs)'``."""
        if not self._topics:
            return 'no topics'
        return ', '.join(f'{name} ({info.msgtype}, {info.count} msgs)'
                         for name, info in self.topics.items())

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[BagMessage]:
        """Yield the messages of ``topics`` (all when None) in log-time order.

        Raises
        ------
        BagError
            If a topic is not in the bag, or the storage turns out to be corrupt while
            reading (the message says after how many messages).
        """
        connections: list[Connection] = list(self._reader.connections)
        if topics is not None:
            wanted = set(topics)
            if missing := wanted - self._topics.keys():
                raise BagError(f'{self.path}: no topic {", ".join(sorted(missing))} in the bag '
                               f'(it has {self.describe_topics()})')
            connections = [c for c in connections if c.topic in wanted]
            if not connections:
                return
        count = 0
        last = None
        try:
            for connection, log_time, data in self._reader.messages(connections=connections):
                yield BagMessage(connection.topic, connection.msgtype, log_time, data)
                count += 1
                last = log_time
        except BagError:
            raise
        except Exception as exc:  # noqa: BLE001 - any decoder failure means a bad file
            where = f'after {count} messages' + (f' (log time {last} ns)' if count else '')
            raise BagError(f'{self.path}: corrupt data {where}: {_describe(exc)}') from exc

    def close(self) -> None:
        """Close the storage files."""
        if self._reader.is_open:
            self._reader.close()

    def __enter__(self) -> BagSource:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()


def open_bag(path: str | Path) -> BagSource:
    """Open a bag directory or a bare ``.mcap``/``.db3`` file for reading.

    Use the returned :class:`BagSource` in a ``with`` block.

    Raises
    ------
    BagError
        If the path does not exist, is not a bag, or a file is truncated or corrupt.
    """
    path = Path(path)
    _check_layout(path)
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags, apsw, zstd, lz4 all raise their own
        raise BagError(f'{path}: cannot read bag: {_describe(exc)}') from exc
    return BagSource(path, reader)


def _check_layout(path: Path) -> None:
    """Raise a precise BagError for the usual ways a path is not a readable bag."""
    if not path.exists():
        raise BagError(f'{path}: does not exist')
    if path.is_dir():
        storage = sorted(p.name for p in path.iterdir() if p.suffix in STORAGE_SUFFIXES)
        if not (path / 'metadata.yaml').is_file():
            if storage:
                raise BagError(
                    f'{path}: no metadata.yaml but {len(storage)} storage file(s) '
                    f'({", ".join(storage[:3])}): a recording that was not closed; '
                    f'{_recover_hint(path)}')
            raise BagError(f'{path}: not a rosbag2 bag (no metadata.yaml and no .mcap or '
                           '.db3 file)')
        for name in storage:
            if name.endswith('.mcap'):
                _check_mcap(path / name, bag=path)
        return
    if path.suffix not in STORAGE_SUFFIXES:
        raise BagError(f'{path}: not a bag (expected a rosbag2 directory, a .mcap or a .db3 '
                       'file)')
    if path.suffix == '.mcap':
        _check_mcap(path, bag=None)


def _check_mcap(file: Path, *, bag: Path | None) -> None:
    """Check the MCAP magic at both ends of ``file`` (cheap; catches truncation)."""
    try:
        with file.open('rb') as stream:
            head = stream.read(len(MCAP_MAGIC))
            size = stream.seek(0, 2)
            tail = b''
            if size >= 2 * len(MCAP_MAGIC):
                stream.seek(-len(MCAP_MAGIC), 2)
                tail = stream.read()
    except OSError as exc:
        raise BagError(f'{file}: cannot read: {exc.strerror}') from exc
    if head != MCAP_MAGIC:
        raise BagError(f'{file}: not an MCAP file (bad magic at offset 0, {size} bytes)')
    if tail != MCAP_MAGIC:
        target = bag if bag is not None else file
        raise BagError(f'{file}: truncated MCAP file ({size} bytes, no footer; was the '
                       f'recorder killed?): {_recover_hint(target)}')


def _recover_hint(target: Path) -> str:
    """The command that makes ``target`` (a bag directory or a .mcap file) readable again."""
    return f'recover it with: scara-ident recover {shlex.quote(str(target))}'


def _describe(exc: BaseException) -> str:
    text = str(exc).strip().rstrip('.') or type(exc).__name__
    return text.splitlines()[0] if text else type(exc).__name__
