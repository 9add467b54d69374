"""Make a bag whose recorder was killed (SIGKILL, power cut, crash) readable again.

A recorder that is stopped normally closes its last MCAP file (summary and footer) and
writes ``metadata.yaml``. Killed, it leaves a bag directory without ``metadata.yaml``
whose last ``.mcap`` file ends in the middle of a chunk. Everything up to the last
complete chunk is on disk: :class:`~scara_ident_ros.bag.mcap_file.McapFileWriter`
flushes every chunk (at most ~1 MiB or ~1 s of messages by default) as soon as it is
complete, with a CRC of its content, and writes schema and channel records before the
chunks that use them.

How to recover, from Python (no ROS needed)::

    from scara_ident_ros.bag import recover_bag
    report = recover_bag('rosbag2_2026_01_01-12_00_00')
    print(report.summary())

:func:`recover_bag` reads each ``.mcap`` file of the bag: a complete one (valid footer
and summary) is kept as it is; a damaged one is scanned record by record from the
start, stopping at the first record that is cut off or a chunk whose length, CRC or
compression does not check out, and everything before that point is rewritten into a
new complete file under the same name (the damaged original is kept next to it as
``<name>.mcap.damaged`` unless ``keep_damaged=False``). Finally ``metadata.yaml`` is
written from what the files hold (topics, types, message counts, offered QoS and type
hashes from the channel metadata), so every rosbag2 reader opens the bag again. A bare
``.mcap`` file can be recovered the same way (no ``metadata.yaml`` then). Running it on
an intact bag changes nothing but ``metadata.yaml``, which is rewritten identically.
Run it only once the recorder process is gone: the file of a live recording also ends
in an incomplete chunk, and would be rewritten under the recorder's feet.
"""
from __future__ import annotations

import re
import struct
import sys
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import lz4.frame

if sys.version_info >= (3, 14):  # pragma: no cover
    from compression import zstd
else:
    from backports import zstd

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.mcap_file import MAGIC, McapFileWriter, Opcode
from scara_ident_ros.bag.metadata import FileSummary, TopicSummary, write_metadata
from scara_ident_ros.bag.qos import parse_offered_qos

__all__ = ['FileRecovery', 'RecoveryReport', 'recover_bag']

_DECOMPRESS: dict[str, Callable[[bytes], bytes]] = {
    '': lambda data: data,
    'zstd': zstd.decompress,
    'lz4': lz4.frame.decompress,
}
_RECORD = struct.Struct('<BQ')
_MESSAGE = struct.Struct('<HIQQ')
_CHUNK = struct.Struct('<QQQI')
_U16 = struct.Struct('<H')
_U32 = struct.Struct('<I')
_U64 = struct.Struct('<Q')


@dataclass(frozen=True)
class FileRecovery:
    """What happened to one storage file.

    Attributes
    ----------
    name : str
        File name inside the bag.
    message_count : int
        Messages the file holds now.
    rewritten : bool
        True if it was damaged and rewritten from its readable part.
    lost_bytes : int
        Bytes at the end of the damaged file that could not be used.
    reason : str
        Why the scan stopped ('' for an intact file).
    """

    name: str
    message_count: int
    rewritten: bool = False
    lost_bytes: int = 0
    reason: str = ''


@dataclass(frozen=True)
class RecoveryReport:
    """The outcome of :func:`recover_bag`."""

    path: Path
    files: tuple[FileRecovery, ...]
    topics: dict[str, int] = field(default_factory=dict)  # topic -> messages

    @property
    def message_count(self) -> int:
        """Messages in the recovered bag."""
        return sum(f.message_count for f in self.files)

    def summary(self) -> str:
        """One line per file, for a log or a terminal."""
        lines = [f'{self.path}: {self.message_count} messages in {len(self.files)} file(s)']
        for f in self.files:
            state = (f'rewritten, {f.lost_bytes} bytes lost ({f.reason})' if f.rewritten
                     else 'intact')
            lines.append(f'  {f.name}: {f.message_count} messages, {state}')
        return '\n'.join(lines)


@dataclass
class _Channel:
    schema_id: int
    topic: str
    encoding: str
    metadata: dict[str, str]


@dataclass
class _Content:
    """Schemas, channels and statistics of one file (intact or rescued)."""

    schemas: dict[int, tuple[str, str, bytes]] = field(default_factory=dict)
    channels: dict[int, _Channel] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)
    start_ns: int = 2**64 - 1
    end_ns: int = 0

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())


class _Damaged(Exception):
    """Where and why the scan of a damaged file stopped."""


def recover_bag(path: str | Path, *, keep_damaged: bool = True) -> RecoveryReport:
    """Rebuild a bag (or a bare ``.mcap`` file) left behind by a killed recorder.

    Parameters
    ----------
    path : str or Path
        The bag directory, or one ``.mcap`` file.
    keep_damaged : bool
        Keep each damaged original as ``<name>.mcap.damaged``.

    Returns
    -------
    RecoveryReport

    Raises
    ------
    BagError
        If the path does not exist, holds no ``.mcap`` file, or a file is not MCAP.
    """
    path = Path(path)
    if not path.exists():
        raise BagError(f'{path}: does not exist')
    if path.is_file():
        recovery, _ = _recover_file(path, keep_damaged)
        return RecoveryReport(path, (recovery,))
    files = sorted((p for p in path.iterdir() if p.suffix == '.mcap' and p.is_file()),
                   key=_split_index)
    if not files:
        other = ' (sqlite3 storage: use ros2 bag reindex)' if any(path.glob('*.db3')) else ''
        raise BagError(f'{path}: no .mcap file to recover{other}')
    recoveries = []
    summaries = []
    topics: dict[str, TopicSummary] = {}
    for file in files:
        recovery, content = _recover_file(file, keep_damaged)
        recoveries.append(recovery)
        summaries.append(FileSummary(file.name, content.start_ns, content.end_ns,
                                     content.message_count))
        for channel_id, channel in content.channels.items():
            schema = content.schemas.get(channel.schema_id)
            count = content.counts.get(channel_id, 0)
            known = topics.get(channel.topic)
            if known is not None:
                topics[channel.topic] = TopicSummary(
                    known.name, known.msgtype, known.message_count + count, known.offered_qos,
                    known.type_hash, known.serialization_format)
                continue
            qos_text = channel.metadata.get('offered_qos_profiles', '')
            try:
                offered = parse_offered_qos(qos_text) if qos_text else []
            except Exception:  # noqa: BLE001 - unreadable QoS metadata: record none
                offered = []
            topics[channel.topic] = TopicSummary(
                channel.topic, schema[0] if schema else '', count, offered,
                channel.metadata.get('topic_type_hash', ''), channel.encoding)
    write_metadata(path, summaries, list(topics.values()))
    return RecoveryReport(path, tuple(recoveries),
                          {name: t.message_count for name, t in topics.items()})


def _split_index(file: Path) -> tuple[int, str]:
    match = re.search(r'_(\d+)$', file.stem)
    return (int(match.group(1)) if match else -1, file.name)


def _recover_file(file: Path, keep_damaged: bool) -> tuple[FileRecovery, _Content]:
    content = _read_intact(file)
    if content is not None:
        return FileRecovery(file.name, content.message_count), content
    tmp = file.with_name(file.name + '.recovering')
    tmp.unlink(missing_ok=True)
    with file.open('rb') as stream:
        size = stream.seek(0, 2)
        stream.seek(0)
        writer: McapFileWriter | None = None
        try:
            content, used, reason, compression = _scan(stream, file, size)
            writer = McapFileWriter(tmp, compression=compression, chunk_duration_ns=0)
            _rewrite(stream, file, used, writer)
            writer.close()
        except BaseException:
            if writer is not None:
                writer.abort()
            tmp.unlink(missing_ok=True)
            raise
    if keep_damaged:
        file.replace(file.with_name(file.name + '.damaged'))
    tmp.replace(file)
    return FileRecovery(file.name, content.message_count, True, size - used, reason), content


def _read_intact(file: Path) -> _Content | None:
    """The content of a complete file from its summary; None if it is damaged."""
    from mcap.reader import make_reader

    try:
        with file.open('rb') as stream:
            stream.seek(-len(MAGIC), 2)
            if stream.read() != MAGIC:
                return None
            stream.seek(0)
            summary = make_reader(stream).get_summary()
    except Exception:  # noqa: BLE001 - any failure here means: scan it
        return None
    if summary is None or summary.statistics is None:
        return None
    content = _Content()
    for schema in summary.schemas.values():
        content.schemas[schema.id] = (schema.name, schema.encoding, schema.data)
    for channel in summary.channels.values():
        content.channels[channel.id] = _Channel(channel.schema_id, channel.topic,
                                                channel.message_encoding,
                                                dict(channel.metadata))
    stats = summary.statistics
    content.counts = {k: v for k, v in stats.channel_message_counts.items()}
    for channel_id in content.channels:
        content.counts.setdefault(channel_id, 0)
    content.start_ns, content.end_ns = stats.message_start_time, stats.message_end_time
    return content


def _read_string(body: bytes, pos: int) -> tuple[str, int]:
    length = _U32.unpack_from(body, pos)[0]
    end = pos + 4 + length
    if end > len(body):
        raise ValueError('string runs past its record')
    return body[pos + 4:end].decode(), end


def _parse_schema(body: bytes) -> tuple[int, tuple[str, str, bytes]]:
    schema_id = _U16.unpack_from(body, 0)[0]
    name, pos = _read_string(body, 2)
    encoding, pos = _read_string(body, pos)
    length = _U32.unpack_from(body, pos)[0]
    return schema_id, (name, encoding, body[pos + 4:pos + 4 + length])


def _parse_channel(body: bytes) -> tuple[int, _Channel]:
    channel_id, schema_id = struct.unpack_from('<HH', body, 0)
    topic, pos = _read_string(body, 4)
    encoding, pos = _read_string(body, pos)
    end = pos + 4 + _U32.unpack_from(body, pos)[0]
    pos += 4
    metadata = {}
    while pos < end:
        key, pos = _read_string(body, pos)
        value, pos = _read_string(body, pos)
        metadata[key] = value
    return channel_id, _Channel(schema_id, topic, encoding, metadata)


def _records(data: bytes, where: str) -> list[tuple[int, bytes]]:
    """Split a chunk's content into (opcode, body); raise _Damaged if it does not add up."""
    records = []
    pos = 0
    while pos < len(data):
        if pos + 9 > len(data):
            raise _Damaged(f'{where}: record header cut off')
        opcode, length = _RECORD.unpack_from(data, pos)
        if pos + 9 + length > len(data):
            raise _Damaged(f'{where}: record at {pos} runs past the chunk')
        records.append((opcode, data[pos + 9:pos + 9 + length]))
        pos += 9 + length
    return records


def _chunk_records(body: bytes, offset: int) -> tuple[str, list[tuple[int, bytes]]]:
    """Check and decompress one chunk record body; return its compression and records."""
    where = f'chunk at offset {offset}'
    try:
        _, _, size, crc = _CHUNK.unpack_from(body, 0)
        compression, pos = _read_string(body, _CHUNK.size)
        length = _U64.unpack_from(body, pos)[0]
        if pos + 8 + length != len(body):
            raise _Damaged(f'{where}: inconsistent lengths')
        if compression not in _DECOMPRESS:
            raise _Damaged(f'{where}: unknown compression {compression!r}')
        data = _DECOMPRESS[compression](body[pos + 8:])
    except _Damaged:
        raise
    except Exception as exc:  # noqa: BLE001 - struct, zstd or lz4 errors
        raise _Damaged(f'{where}: cannot decode ({exc})') from exc
    if len(data) != size or (crc and zlib.crc32(data) != crc):
        raise _Damaged(f'{where}: size or CRC mismatch')
    return compression, _records(data, where)


def _top_level(stream: BinaryIO, file: Path, size: int) -> Iterator[tuple[int, int, bytes]]:
    """Yield (offset, opcode, body) of the data section; raise _Damaged where it breaks."""
    head = stream.read(len(MAGIC))
    if head != MAGIC:
        if len(head) < len(MAGIC) and MAGIC.startswith(head):
            raise _Damaged('file cut off inside the magic')
        raise BagError(f'{file}: not an MCAP file (bad magic at offset 0)')
    offset = len(MAGIC)
    while offset < size:
        header = stream.read(9)
        if len(header) < 9:
            raise _Damaged(f'record header at offset {offset} cut off')
        opcode, length = _RECORD.unpack(header)
        if offset + 9 + length > size:
            raise _Damaged(f'record at offset {offset} cut off ({length} bytes announced, '
                           f'{size - offset - 9} on disk)')
        body = stream.read(length)
        yield offset, opcode, body
        offset += 9 + length
        if opcode in (Opcode.DATA_END, Opcode.FOOTER):
            raise _Damaged(f'data section ends at offset {offset} but the summary is '
                           'unreadable')


def _apply(content: _Content, opcode: int, body: bytes,
           on_message: Callable[[int, int, bytes], None] | None) -> None:
    if opcode == Opcode.SCHEMA:
        schema_id, schema = _parse_schema(body)
        content.schemas[schema_id] = schema
    elif opcode == Opcode.CHANNEL:
        channel_id, channel = _parse_channel(body)
        content.channels[channel_id] = channel
        content.counts.setdefault(channel_id, 0)
    elif opcode == Opcode.MESSAGE:
        channel_id, _, log_time, _ = _MESSAGE.unpack_from(body, 0)
        if channel_id not in content.channels:
            raise ValueError(f'message on undeclared channel {channel_id}')
        content.counts[channel_id] += 1
        content.start_ns = min(content.start_ns, log_time)
        content.end_ns = max(content.end_ns, log_time)
        if on_message is not None:
            on_message(channel_id, log_time, body[_MESSAGE.size:])


def _scan(stream: BinaryIO, file: Path, size: int) -> tuple[_Content, int, str, str]:
    """Find how much of a damaged file is usable.

    Returns the content of the usable part, its length in bytes, why the scan stopped
    and the compression of its chunks ('none' if none was compressed).
    """
    content = _Content()
    used = 0
    compression = 'none'
    reason = 'end of file'
    try:
        for offset, opcode, body in _top_level(stream, file, size):
            trial = _Content(dict(content.schemas), dict(content.channels),
                             dict(content.counts), content.start_ns, content.end_ns)
            if opcode == Opcode.CHUNK:
                name, records = _chunk_records(body, offset)
                for inner, inner_body in records:
                    _apply(trial, inner, inner_body, None)
                compression = name or compression
            else:
                _apply(trial, opcode, body, None)
            content = trial
            used = offset + 9 + len(body)
    except _Damaged as exc:
        reason = str(exc)
    except (ValueError, struct.error, UnicodeDecodeError) as exc:
        reason = f'bad record after offset {used}: {exc}'
    return content, used, reason, compression


def _rewrite(stream: BinaryIO, file: Path, used: int, writer: McapFileWriter) -> None:
    """Copy the first ``used`` bytes' schemas, channels and messages into ``writer``."""
    stream.seek(0)
    content = _Content()
    batch: list[tuple[int, int, bytes]] = []

    def on_message(channel_id: int, log_time: int, data: bytes) -> None:
        batch.append((channel_id, log_time, data))

    def apply(opcode: int, body: bytes) -> None:
        known_schemas = set(content.schemas)
        known_channels = set(content.channels)
        _apply(content, opcode, body, on_message)
        for schema_id in content.schemas.keys() - known_schemas:
            name, encoding, data = content.schemas[schema_id]
            writer.add_schema(schema_id, name, encoding, data)
        for channel_id in content.channels.keys() - known_channels:
            channel = content.channels[channel_id]
            writer.add_channel(channel_id, channel.schema_id, channel.topic, channel.encoding,
                               channel.metadata)

    try:
        for offset, opcode, body in _top_level(stream, file, used):
            if opcode == Opcode.CHUNK:
                for inner, inner_body in _chunk_records(body, offset)[1]:
                    apply(inner, inner_body)
            else:
                apply(opcode, body)
            writer.write_batch(batch)
            batch.clear()
    except _Damaged:
        pass  # the end of the usable part (already established by _scan)
