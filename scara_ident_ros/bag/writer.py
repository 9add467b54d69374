"""Write a rosbag2 bag directory with MCAP storage, split by size or duration.

Layout, as ``ros2 bag record -s mcap`` makes it::

    <bag>/
      metadata.yaml        written by close() (or by recover_bag() after a crash)
      <bag>_0.mcap         the first storage file
      <bag>_1.mcap         the next one, after a split (max_file_size / max_file_duration_ns)

Why not ``rosbags.rosbag2.Writer``: it writes one file (no splitting), closes a chunk only
at 1 MiB and never flushes before ``close()`` (a recorder killed at 1 kHz would lose
seconds). :class:`BagWriter` keeps its format (metadata version 9, ``ros2msg`` schemas
with rosbags' RIHS01 hashes, offered QoS in the channel metadata) and adds splits, chunks
bounded in size *and* time, a flush after every chunk, and ``lz4``; each storage file is
a :class:`~scara_ident_ros.bag.mcap_file.McapFileWriter`. Its bags read back with rosbags,
``mcap`` + ``mcap_ros2`` and :func:`~scara_ident_ros.bag.open_bag`.

Timestamps are integer nanoseconds; a message's log time is written as its publish
time too.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml
from rosbags.interfaces import Qos

from scara_ident_ros.bag.closing_writer import ClosingWriter
from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.mcap_file import COMPRESSIONS, McapFileWriter
from scara_ident_ros.bag.metadata import FileSummary, TopicSummary, write_metadata
from scara_ident_ros.bag.qos import dump_offered_qos
from scara_ident_ros.bag.typedefs import TypeDefinition, message_definition

__all__ = ['BagWriter', 'Connection', 'channel_metadata']

_SLICE = 256  # messages written between two split checks


@dataclass(frozen=True)
class Connection:
    """A topic being recorded: its id in the MCAP files (channel id) and what describes it."""

    id: int
    topic: str
    msgtype: str
    definition: TypeDefinition
    offered_qos: tuple[Qos, ...]
    serialization_format: str = 'cdr'


def channel_metadata(connection: Connection) -> dict[str, str]:
    """MCAP channel metadata as rosbag2 writes it (offered QoS as a YAML string, hash)."""
    metadata = {'offered_qos_profiles': yaml.safe_dump(
        dump_offered_qos(connection.offered_qos), sort_keys=False).strip()
        if connection.offered_qos else ''}
    if connection.definition.type_hash:
        metadata['topic_type_hash'] = connection.definition.type_hash
    return metadata


class BagWriter(ClosingWriter):
    """Record messages into a new rosbag2 bag directory; see the module docstring.

    Parameters
    ----------
    path : str or Path
        The bag directory; must not exist (it is never overwritten).
    max_file_size, max_file_duration_ns : int
        Start a new storage file once one holds this many bytes or spans this much log
        time (ns); 0: never.
    compression, chunk_size, chunk_duration_ns, clock
        As in :class:`~scara_ident_ros.bag.mcap_file.McapFileWriter`.

    Raises
    ------
    BagError
        If ``path`` exists or an option is invalid.
    """

    def __init__(self, path: str | Path, *, compression: str = 'none', max_file_size: int = 0,
                 max_file_duration_ns: int = 0, chunk_size: int = 1 << 20,
                 chunk_duration_ns: int = 1_000_000_000,
                 clock: Callable[[], int] = time.monotonic_ns) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f'{self.path} exists already, not overwriting')
        if compression not in COMPRESSIONS:
            raise BagError(f'{self.path}: compression must be one of '
                           f'{", ".join(COMPRESSIONS)}, got {compression!r}')
        if min(max_file_size, max_file_duration_ns, chunk_size - 1, chunk_duration_ns) < 0:
            raise BagError(f'{self.path}: sizes and durations must be >= 0 (chunk_size > 0)')
        self.compression = compression
        self.max_file_size = max_file_size
        self.max_file_duration_ns = max_file_duration_ns
        self.chunk_size = chunk_size
        self.chunk_duration_ns = chunk_duration_ns
        self._clock = clock
        self.connections: list[Connection] = []
        self._schemas: dict[str, int] = {}  # msgtype -> schema id
        self._files: list[FileSummary] = []
        self._counts: dict[int, int] = {}  # connection id -> messages in closed files
        self._file: McapFileWriter | None = None
        self._file_first_ns: int | None = None  # log time of the open file's first message

    # -- opening and files ---------------------------------------------------------------

    def open(self) -> BagWriter:
        """Create the directory and the first storage file; return self."""
        try:
            self.path.mkdir(parents=True)
        except FileExistsError:
            raise BagError(f'{self.path} exists already, not overwriting') from None
        except OSError as exc:
            raise BagError(f'{self.path}: cannot create the bag directory: {exc.strerror}'
                           ) from exc
        self._open_file()
        return self

    @property
    def file_names(self) -> list[str]:
        """Names of the storage files so far (the open one last)."""
        names = [f.name for f in self._files]
        if self._file is not None:
            names.append(self._file.path.name)
        return names

    def _open_file(self) -> None:
        name = f'{self.path.name}_{len(self._files)}.mcap'
        self._file = McapFileWriter(self.path / name, compression=self.compression,
                                    chunk_size=self.chunk_size,
                                    chunk_duration_ns=self.chunk_duration_ns, clock=self._clock)
        self._file_first_ns = None
        for msgtype, schema_id in self._schemas.items():
            definition = _definition_of(self.connections, msgtype)
            self._file.add_schema(schema_id, msgtype, definition.encoding,
                                  definition.text.encode())
        for connection in self.connections:
            self._add_channel(connection)

    def _close_file(self) -> None:
        file = self._require_open()
        file.close()
        for channel_id, count in file.channel_counts.items():
            self._counts[channel_id] = self._counts.get(channel_id, 0) + count
        self._files.append(FileSummary(file.path.name, file.start_ns, file.end_ns,
                                       file.message_count))
        self._file = None

    def split(self) -> None:
        """Close the current storage file and continue in a new one."""
        self._close_file()
        self._open_file()

    def _require_open(self) -> McapFileWriter:
        if self._file is None:
            raise BagError(f'{self.path}: the bag is not open')
        return self._file

    # -- connections and messages --------------------------------------------------------

    def add_connection(self, topic: str, msgtype: str, *, offered_qos: Sequence[Qos] = (),
                       definition: TypeDefinition | None = None,
                       serialization_format: str = 'cdr') -> Connection:
        """Register a topic; return its :class:`Connection` (``.id`` is used to write).

        ``definition`` defaults to :func:`~scara_ident_ros.bag.typedefs.message_definition`.
        """
        file = self._require_open()
        if any(c.topic == topic for c in self.connections):
            raise BagError(f'{self.path}: topic {topic} is already recorded')
        definition = definition or message_definition(msgtype)
        connection = Connection(len(self.connections) + 1, topic, msgtype, definition,
                                tuple(offered_qos), serialization_format)
        if msgtype not in self._schemas:
            self._schemas[msgtype] = len(self._schemas) + 1
            file.add_schema(self._schemas[msgtype], msgtype, definition.encoding,
                            definition.text.encode())
        self.connections.append(connection)
        self._add_channel(connection)
        return connection

    def _add_channel(self, connection: Connection) -> None:
        self._require_open().add_channel(
            connection.id, self._schemas[connection.msgtype], connection.topic,
            connection.serialization_format, channel_metadata(connection))

    def write(self, connection_id: int, log_time_ns: int, data: bytes) -> None:
        """Write one message."""
        self.write_batch(((connection_id, log_time_ns, data),))

    def write_batch(self, messages: Sequence[tuple[int, int, bytes]]) -> None:
        """Write messages given as ``(connection_id, log_time_ns, data)``, in order."""
        for first in range(0, len(messages), _SLICE):
            part = messages[first:first + _SLICE] if len(messages) > _SLICE else messages
            file = self._require_open()
            if self.max_file_duration_ns:
                if self._file_first_ns is None:
                    self._file_first_ns = part[0][1]
                elif part[-1][1] - self._file_first_ns >= self.max_file_duration_ns:
                    self.split()
                    file = self._require_open()
                    self._file_first_ns = part[0][1]
            try:
                file.write_batch(part)
            except ValueError as exc:
                raise BagError(str(exc)) from None
            if self.max_file_size and file.size >= self.max_file_size:
                self.split()

    def poll(self) -> None:
        """Write the open chunk if it is ``chunk_duration_ns`` old (call it periodically)."""
        if self._file is not None:
            self._file.poll()

    @property
    def message_count(self) -> int:
        """Messages written so far, all files."""
        return sum(self.counts_by_id().values())

    def counts_by_id(self) -> dict[int, int]:
        """Messages written so far per connection id."""
        counts = dict(self._counts)
        if self._file is not None:
            for channel_id, count in self._file.channel_counts.items():
                counts[channel_id] = counts.get(channel_id, 0) + count
        return counts

    # -- closing -------------------------------------------------------------------------

    def close(self) -> Path:
        """Close the last storage file and write ``metadata.yaml``; return its path."""
        if self._file is None:
            raise BagError(f'{self.path}: the bag is not open')
        self._close_file()
        topics = [TopicSummary(c.topic, c.msgtype, self._counts.get(c.id, 0), c.offered_qos,
                               c.definition.type_hash, c.serialization_format)
                  for c in self.connections]
        return write_metadata(self.path, self._files, topics)

    def abort(self) -> None:
        """Close the open storage file as it is, without summary or metadata."""
        if self._file is not None:
            self._file.abort()
            self._file = None

    def __enter__(self) -> BagWriter:
        return self.open()


def _definition_of(connections: Sequence[Connection], msgtype: str) -> TypeDefinition:
    """The definition a connection of ``msgtype`` was registered with."""
    return next(c.definition for c in connections if c.msgtype == msgtype)
