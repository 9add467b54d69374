"""One MCAP file, written by the ``mcap`` library, each chunk on disk once it is complete.

This is the storage layer of :class:`~scara_ident_ros.bag.writer.BagWriter`. The pinned
``mcap`` library's :class:`~mcap.writer.Writer` writes the records: the chunks with their
compression (``zstd`` or ``lz4``) and CRC, the message indexes, and the summary (schemas,
channels, chunk indexes, statistics, summary offsets) and footer that indexed readers
(``rosbags``, ``mcap``) need. This class adds what a recorder that must not lose much
when it is killed needs:

- It closes a chunk itself, when the chunk holds ``chunk_size`` bytes or its first
  message is ``chunk_duration_ns`` old (checked on every write and on
  :meth:`McapFileWriter.poll`), with ``Writer.flush()``, which writes it and flushes the
  file: a SIGKILL loses at most the open chunk, ~1 MiB or ~1 s by default.
- Schema and channel records go into the chunk that is open when they are added, before
  the first message that uses them, so a file cut anywhere reads from its start up to its
  last complete chunk (:func:`~scara_ident_ros.bag.recovery.recover_bag`).
- Schema and channel ids are the caller's (the same in every file of a split bag),
  checked against those the library gives (1, 2, ...).

In the recorder node the library's per-message cost is within the run-to-run spread
(docs/results.md).
"""
from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from mcap.writer import CompressionType, Writer

from scara_ident_ros.bag.closing_writer import ClosingWriter

__all__ = ['COMPRESSIONS', 'MAGIC', 'McapFileWriter', 'PROFILE']

MAGIC = b'\x89MCAP0\r\n'
PROFILE = 'ros2'
LIBRARY = 'scara_ident_ros'
_NO_TIME = 2**64 - 1
_NEVER = 2**63  # the library's own size limit: this class closes chunks
_MESSAGE_OVERHEAD = 31  # bytes of a message record before its payload

#: Chunk compression name -> the library's setting.
COMPRESSIONS: dict[str, CompressionType] = {
    'none': CompressionType.NONE,
    'zstd': CompressionType.ZSTD,
    'lz4': CompressionType.LZ4,
}


class McapFileWriter(ClosingWriter):
    """Write one MCAP file; see the module docstring for the guarantees.

    Parameters
    ----------
    compression : {'none', 'zstd', 'lz4'}
        Chunk compression (MCAP-level, transparent to every MCAP reader).
    chunk_size : int
        Close a chunk once it holds this many bytes (uncompressed).
    chunk_duration_ns : int
        Close a chunk once its first message is this old (wall clock, ns); 0: no limit.
    clock : callable, optional
        Monotonic clock (ns) for ``chunk_duration_ns``.
    """

    def __init__(self, path: Path, *, compression: str = 'none', chunk_size: int = 1 << 20,
                 chunk_duration_ns: int = 1_000_000_000,
                 clock: Callable[[], int] = time.monotonic_ns) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f'compression must be one of {", ".join(COMPRESSIONS)}, '
                             f'got {compression!r}')
        self.path = path
        self.compression = compression
        self.chunk_size = chunk_size
        self.chunk_duration_ns = chunk_duration_ns
        self._clock = clock
        self._file = path.open('xb')
        self._writer = Writer(self._file, chunk_size=_NEVER,
                              compression=COMPRESSIONS[compression])
        self._writer.start(PROFILE, LIBRARY)
        self._file.flush()
        self._schemas = 0
        self._channels: Counter[int] = Counter()  # channel id -> messages
        self._written = self._file.tell()  # bytes on disk
        self._open_bytes = 0  # uncompressed bytes added since the last chunk was written
        self._chunk_opened: int | None = None  # clock() at the open chunk's first message
        self.message_count = 0
        self.start_ns = _NO_TIME  # earliest log time written
        self.end_ns = 0  # latest log time written

    @property
    def size(self) -> int:
        """Bytes written so far plus the open chunk (uncompressed), bytes."""
        return self._written + self._open_bytes

    @property
    def channel_counts(self) -> dict[int, int]:
        """Messages written per channel id (open chunk included)."""
        return dict(self._channels)

    def add_schema(self, schema_id: int, name: str, encoding: str, data: bytes) -> None:
        """Add a schema record (e.g. ``'sensor_msgs/msg/JointState'``, ``'ros2msg'``)."""
        if schema_id != self._schemas + 1:
            raise ValueError(f'{self.path}: schema {name} must have id {self._schemas + 1}, '
                             f'got {schema_id}')
        self._writer.register_schema(name, encoding, data)
        self._schemas += 1

    def add_channel(self, channel_id: int, schema_id: int, topic: str,
                    message_encoding: str = 'cdr',
                    metadata: Mapping[str, str] | None = None) -> None:
        """Add a channel record; ``schema_id`` must have been added (0 = no schema)."""
        if schema_id > self._schemas:
            raise ValueError(f'{self.path}: channel {topic} refers to unknown schema '
                             f'{schema_id}')
        if channel_id != len(self._channels) + 1:
            raise ValueError(f'{self.path}: channel {topic} must have id '
                             f'{len(self._channels) + 1}, got {channel_id}')
        self._writer.register_channel(topic, message_encoding, schema_id, dict(metadata or {}))
        self._channels[channel_id] = 0

    def write(self, channel_id: int, log_time_ns: int, data: bytes) -> None:
        """Add one message (``log_time_ns`` is also written as its publish time)."""
        self.write_batch(((channel_id, log_time_ns, data),))

    def write_batch(self, messages: Sequence[tuple[int, int, bytes]]) -> None:
        """Add messages given as ``(channel_id, log_time_ns, data)``, in order."""
        if messages and self._chunk_opened is None:
            self._chunk_opened = self._clock()
        add = self._writer.add_message
        counts = self._channels
        limit = self.chunk_size
        start, end, open_bytes = self.start_ns, self.end_ns, self._open_bytes
        try:
            for channel_id, log_time, data in messages:
                if channel_id not in counts:
                    raise ValueError(f'{self.path}: message for unknown channel {channel_id}')
                add(channel_id, log_time, data, log_time)
                counts[channel_id] += 1
                if log_time < start:
                    start = log_time
                if log_time > end:
                    end = log_time
                open_bytes += _MESSAGE_OVERHEAD + len(data)
                if open_bytes >= limit:
                    self.message_count = sum(counts.values())
                    self.flush_chunk()
                    open_bytes = 0
        finally:
            self.start_ns, self.end_ns, self._open_bytes = start, end, open_bytes
            self.message_count = sum(counts.values())
        self.poll()

    def poll(self) -> None:
        """Write the open chunk if its first message is ``chunk_duration_ns`` old."""
        if (self._chunk_opened is not None and self.chunk_duration_ns
                and self._clock() - self._chunk_opened >= self.chunk_duration_ns):
            self.flush_chunk()

    def flush_chunk(self) -> None:
        """Write the open chunk (if any) and its message indexes, and flush the file."""
        self._writer.flush()
        self._chunk_opened = None
        self._written = self._file.tell()
        self._open_bytes = 0

    def close(self) -> None:
        """Write the last chunk, the summary and the footer, and close the file."""
        if self._file.closed:
            return
        self._writer.finish()
        self._file.close()

    def abort(self) -> None:
        """Close the file as it is (no summary, no footer)."""
        if not self._file.closed:
            self._file.close()

