"""One MCAP file written chunk by chunk, each chunk on disk as soon as it is complete.

This is the storage layer of :class:`~scara_ident_ros.bag.writer.BagWriter`: a small
writer of the `MCAP format <https://mcap.dev/spec>`_ (profile ``ros2``) built for a
recorder that must not lose much when it is killed:

- Messages collect in an in-memory chunk that is closed (optionally compressed,
  ``zstd`` or ``lz4``, with a CRC of its content), written with its message index
  records and flushed to the operating system when it holds ``chunk_size`` bytes or
  its first message is ``chunk_duration_ns`` old (checked on every write and on
  :meth:`McapFileWriter.poll`). A SIGKILL therefore loses at most the open chunk:
  ~1 MiB or ~1 s by default.
- Schema and channel records go to the top level of the data section, and are flushed,
  when they are added, so every complete chunk on disk can be decoded on its own
  (:func:`~scara_ident_ros.bag.recovery.recover_bag` relies on this).
- :meth:`McapFileWriter.close` writes the summary (schemas, channels, chunk indexes,
  statistics, summary offsets) and the footer that indexed readers (``rosbags``,
  ``mcap``) need.

The per-message cost is one ``struct.pack`` and a few list appends
(:meth:`McapFileWriter.write_batch` takes a list of messages to keep the Python loop
tight), which matters at tens of thousands of messages per second.
"""
from __future__ import annotations

import struct
import sys
import time
import zlib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import TracebackType

import lz4.frame
import numpy as np

if sys.version_info >= (3, 14):  # pragma: no cover
    from compression import zstd
else:
    from backports import zstd

__all__ = ['COMPRESSIONS', 'MAGIC', 'McapFileWriter', 'Opcode', 'PROFILE']

MAGIC = b'\x89MCAP0\r\n'
PROFILE = 'ros2'
LIBRARY = 'scara_ident_ros'
ZSTD_LEVEL = 1  # fastest level: ~2.5 ms per MiB here, nearly the ratio of level 3


class Opcode:
    """MCAP record opcodes (https://mcap.dev/spec#records)."""

    HEADER = 0x01
    FOOTER = 0x02
    SCHEMA = 0x03
    CHANNEL = 0x04
    MESSAGE = 0x05
    CHUNK = 0x06
    MESSAGE_INDEX = 0x07
    CHUNK_INDEX = 0x08
    STATISTICS = 0x0B
    SUMMARY_OFFSET = 0x0E
    DATA_END = 0x0F


#: Chunk compression name (as written in the chunk record) -> compressor.
COMPRESSIONS: dict[str, Callable[[bytes], bytes]] = {
    'none': lambda data: data,
    'zstd': lambda data: zstd.compress(data, level=ZSTD_LEVEL),
    'lz4': lambda data: lz4.frame.compress(data),
}

# opcode u8, record length u64, channel_id u16, sequence u32, log_time u64, publish_time u64
_MESSAGE = struct.Struct('<BQHIQQ')
_MESSAGE_OVERHEAD = _MESSAGE.size  # 31 bytes before the payload
_RECORD = struct.Struct('<BQ')
_U16 = struct.Struct('<H')
_U32 = struct.Struct('<I')
_U64 = struct.Struct('<Q')
_NO_TIME = 2**64 - 1


def _string(text: str) -> bytes:
    data = text.encode()
    return _U32.pack(len(data)) + data


def _prefixed(data: bytes) -> bytes:
    return _U32.pack(len(data)) + data


def _record(opcode: int, body: bytes) -> bytes:
    return _RECORD.pack(opcode, len(body)) + body


def _string_map(items: Mapping[str, str]) -> bytes:
    return _prefixed(b''.join(_string(k) + _string(v) for k, v in sorted(items.items())))


class McapFileWriter:
    """Write one MCAP file; see the module docstring for the guarantees.

    Parameters
    ----------
    path : Path
        The file to create; it must not exist.
    compression : {'none', 'zstd', 'lz4'}
        Chunk compression (MCAP-level, transparent to every MCAP reader).
    chunk_size : int
        Close a chunk once it holds this many bytes (uncompressed), bytes.
    chunk_duration_ns : int
        Close a chunk once its first message is this old (wall clock), ns; 0 = no limit.
    clock : callable, optional
        Monotonic clock in ns for ``chunk_duration_ns`` (tests pass a fake one).
    """

    def __init__(self, path: Path, *, compression: str = 'none', chunk_size: int = 1 << 20,
                 chunk_duration_ns: int = 1_000_000_000,
                 clock: Callable[[], int] = time.monotonic_ns) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f'compression must be one of {", ".join(COMPRESSIONS)}, '
                             f'got {compression!r}')
        self.path = path
        self.compression = compression
        self._compress = COMPRESSIONS[compression]
        self._compression_name = '' if compression == 'none' else compression
        self.chunk_size = chunk_size
        self.chunk_duration_ns = chunk_duration_ns
        self._clock = clock
        self._file = path.open('xb')
        self._written = 0
        self._schemas: dict[int, bytes] = {}  # id -> record
        self._channels: dict[int, bytes] = {}  # id -> record
        self._chunk_indexes: list[bytes] = []
        self._channel_counts: dict[int, int] = {}
        self.message_count = 0
        self.start_ns = _NO_TIME  # earliest log time written
        self.end_ns = 0  # latest log time written
        self._new_chunk()
        self._emit(MAGIC + _record(Opcode.HEADER, _string(PROFILE) + _string(LIBRARY)))

    # -- the open chunk ------------------------------------------------------------------

    def _new_chunk(self) -> None:
        self._parts: list[bytes] = []
        self._offset = 0  # uncompressed bytes in the open chunk
        self._index: dict[int, list[int]] = {}  # channel -> [log_time, offset, ...]
        self._chunk_start = _NO_TIME
        self._chunk_end = 0
        self._chunk_opened = 0  # clock() at the first message

    def _emit(self, data: bytes) -> None:
        self._file.write(data)
        self._file.flush()
        self._written += len(data)

    @property
    def size(self) -> int:
        """Bytes written so far plus the open chunk (uncompressed), bytes."""
        return self._written + self._offset

    @property
    def channel_counts(self) -> dict[int, int]:
        """Messages written per channel id (open chunk included)."""
        counts = dict(self._channel_counts)
        for channel, index in self._index.items():
            counts[channel] = counts.get(channel, 0) + len(index) // 2
        return counts

    def add_schema(self, schema_id: int, name: str, encoding: str, data: bytes) -> None:
        """Write a schema record (e.g. ``'sensor_msgs/msg/JointState'``, ``'ros2msg'``)."""
        record = _record(Opcode.SCHEMA, _U16.pack(schema_id) + _string(name)
                         + _string(encoding) + _prefixed(data))
        self._schemas[schema_id] = record
        self._emit(record)

    def add_channel(self, channel_id: int, schema_id: int, topic: str,
                    message_encoding: str = 'cdr',
                    metadata: Mapping[str, str] | None = None) -> None:
        """Write a channel record; ``schema_id`` must have been added (0 = no schema)."""
        if schema_id and schema_id not in self._schemas:
            raise ValueError(f'{self.path}: channel {topic} refers to unknown schema '
                             f'{schema_id}')
        record = _record(Opcode.CHANNEL, _U16.pack(channel_id) + _U16.pack(schema_id)
                         + _string(topic) + _string(message_encoding)
                         + _string_map(metadata or {}))
        self._channels[channel_id] = record
        self._channel_counts.setdefault(channel_id, 0)
        self._emit(record)

    def write(self, channel_id: int, log_time_ns: int, data: bytes) -> None:
        """Add one message (``log_time_ns`` is also written as its publish time)."""
        self.write_batch(((channel_id, log_time_ns, data),))

    def write_batch(self, messages: Sequence[tuple[int, int, bytes]]) -> None:
        """Add messages given as ``(channel_id, log_time_ns, data)``, in order."""
        done = 0
        while done < len(messages):
            done = self._fill(messages, done)
            if self._offset >= self.chunk_size:
                self.flush_chunk()
        self.poll()

    def _fill(self, messages: Sequence[tuple[int, int, bytes]], first: int) -> int:
        """Add ``messages[first:]`` until the chunk is full; return the next index."""
        parts = self._parts
        index = self._index
        offset = self._offset
        limit = self.chunk_size
        pack = _MESSAGE.pack
        start = self._chunk_start
        end = self._chunk_end
        if not parts:
            self._chunk_opened = self._clock()
        position = first
        for channel_id, log_time, data in messages[first:] if first else messages:
            entries = index.get(channel_id)
            if entries is None:
                if channel_id not in self._channels:
                    self._offset, self._chunk_start, self._chunk_end = offset, start, end
                    self.message_count += position - first
                    raise ValueError(f'{self.path}: message for unknown channel {channel_id}')
                entries = index[channel_id] = []
            position += 1
            parts.append(pack(Opcode.MESSAGE, len(data) + 22, channel_id, 0, log_time,
                              log_time))
            parts.append(data)
            entries.append(log_time)
            entries.append(offset)
            offset += _MESSAGE_OVERHEAD + len(data)
            if log_time < start:
                start = log_time
            if log_time > end:
                end = log_time
            if offset >= limit:
                break
        self._offset = offset
        self._chunk_start = start
        self._chunk_end = end
        self.message_count += position - first
        return position

    def poll(self) -> None:
        """Close the open chunk if its first message is ``chunk_duration_ns`` old."""
        if (self._parts and self.chunk_duration_ns
                and self._clock() - self._chunk_opened >= self.chunk_duration_ns):
            self.flush_chunk()

    def flush_chunk(self) -> None:
        """Write the open chunk (if any) and its message indexes, and flush the file."""
        if not self._parts:
            return
        content = b''.join(self._parts)
        compressed = self._compress(content)
        body = (_U64.pack(self._chunk_start) + _U64.pack(self._chunk_end)
                + _U64.pack(len(content)) + _U32.pack(zlib.crc32(content))
                + _string(self._compression_name) + _U64.pack(len(compressed)))
        chunk = _record(Opcode.CHUNK, body + compressed)
        chunk_start = self._written
        indexes = []
        offsets = []
        position = chunk_start + len(chunk)
        for channel_id in sorted(self._index):
            entries = np.array(self._index[channel_id], dtype='<u8').reshape(-1, 2)
            if (np.diff(entries[:, 0].astype(np.int64)) < 0).any():  # clock stepped back
                entries = entries[np.argsort(entries[:, 0], kind='stable')]
            record = _record(Opcode.MESSAGE_INDEX, _U16.pack(channel_id)
                             + _prefixed(entries.tobytes()))
            offsets.append(_U16.pack(channel_id) + _U64.pack(position))
            indexes.append(record)
            position += len(record)
            self._channel_counts[channel_id] = (self._channel_counts.get(channel_id, 0)
                                                + entries.shape[0])
        index_bytes = b''.join(indexes)
        self._chunk_indexes.append(_record(
            Opcode.CHUNK_INDEX,
            _U64.pack(self._chunk_start) + _U64.pack(self._chunk_end) + _U64.pack(chunk_start)
            + _U64.pack(len(chunk)) + _prefixed(b''.join(offsets))
            + _U64.pack(len(index_bytes)) + _string(self._compression_name)
            + _U64.pack(len(compressed)) + _U64.pack(len(content))))
        self.start_ns = min(self.start_ns, self._chunk_start)
        self.end_ns = max(self.end_ns, self._chunk_end)
        self._new_chunk()
        self._emit(chunk + index_bytes)

    # -- closing -------------------------------------------------------------------------

    def close(self) -> None:
        """Write the last chunk, the summary and the footer, and close the file."""
        if self._file.closed:
            return
        self.flush_chunk()
        self._file.write(_record(Opcode.DATA_END, _U32.pack(0)))
        self._written += 9 + 4
        summary_start = self._written
        groups: list[tuple[int, bytes]] = [
            (Opcode.SCHEMA, b''.join(self._schemas[k] for k in sorted(self._schemas))),
            (Opcode.CHANNEL, b''.join(self._channels[k] for k in sorted(self._channels))),
            (Opcode.CHUNK_INDEX, b''.join(self._chunk_indexes)),
        ]
        counts = self.channel_counts
        groups.append((Opcode.STATISTICS, _record(Opcode.STATISTICS, struct.pack(
            '<QHIIIIQQ', self.message_count, len(self._schemas), len(self._channels), 0, 0,
            len(self._chunk_indexes), self.start_ns if self.message_count else 0,
            self.end_ns) + _prefixed(b''.join(
                _U16.pack(k) + _U64.pack(v) for k, v in sorted(counts.items()))))))
        summary = bytearray()
        offsets = bytearray()
        for opcode, data in groups:
            if data:
                offsets += _record(Opcode.SUMMARY_OFFSET, struct.pack(
                    '<BQQ', opcode, summary_start + len(summary), len(data)))
                summary += data
        summary_offset_start = summary_start + len(summary)
        summary += offsets
        footer_head = _RECORD.pack(Opcode.FOOTER, 20) + _U64.pack(summary_start) \
            + _U64.pack(summary_offset_start)
        crc = zlib.crc32(footer_head, zlib.crc32(summary))
        self._file.write(bytes(summary) + footer_head + _U32.pack(crc) + MAGIC)
        self._file.close()

    def abort(self) -> None:
        """Close the file as it is (no summary, no footer)."""
        if not self._file.closed:
            self._file.close()

    def __enter__(self) -> McapFileWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
