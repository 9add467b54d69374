"""Make a bag whose recorder was killed (SIGKILL, power cut, crash) readable again.

Killed, a recorder leaves a bag directory without ``metadata.yaml`` whose last ``.mcap``
file ends in the middle of a chunk; everything up to the last complete chunk is on disk
(:class:`~scara_ident_ros.bag.mcap_file.McapFileWriter` says why).

:func:`recover_bag` keeps each complete ``.mcap`` file as it is and reads a damaged one
record by record (``mcap``'s ``StreamReader``, CRCs checked) up to the first record cut
off or chunk that does not check out, copying what comes before into a new complete file
under the same name (the original kept as ``<name>.mcap.damaged`` unless
``keep_damaged=False``). Then it writes ``metadata.yaml`` from what the files hold, so
every rosbag2 reader opens the bag again; on an intact bag that file comes out identical.
Run it only once the recorder process is gone: a live recording's file also ends in an
incomplete chunk.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.mcap_file import MAGIC, McapFileWriter
from scara_ident_ros.bag.metadata import FileSummary, TopicSummary, write_metadata
from scara_ident_ros.bag.qos import parse_offered_qos

__all__ = ['FileRecovery', 'RecoveryReport', 'recover_bag']

@dataclass(frozen=True)
class FileRecovery:
    """What happened to one storage file.

    Attributes
    ----------
    name : str
        File name inside the bag.
    rewritten : bool
        It was damaged and rewritten from its readable part.
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
    salvage = _Salvage(tmp)
    try:
        with file.open('rb') as stream:
            size = stream.seek(0, 2)
            stream.seek(0)
            reason = salvage.run(stream, size, file)
        salvage.close()
    except BaseException:
        salvage.abort()
        tmp.unlink(missing_ok=True)
        raise
    if keep_damaged:
        file.replace(file.with_name(file.name + '.damaged'))
    tmp.replace(file)
    content = salvage.content
    return (FileRecovery(file.name, content.message_count, True, size - salvage.used, reason),
            content)


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


class _Exact:
    """A file read through ``mcap``'s StreamReader that raises on a read it cannot fill.

    The StreamReader takes a short read (a record cut off by the kill) for the whole record;
    here it is where the usable part ends. ``tell`` is the end of the last record read.
    """

    def __init__(self, stream: BinaryIO, size: int) -> None:
        self._raw = stream
        self._size = size
        self._offset = stream.tell()

    def read(self, length: int) -> bytes:
        data = self._raw.read(length)
        if len(data) < length:
            raise _Damaged(f'{length} bytes wanted at offset {self._offset}, '
                           f'{self._size - self._offset} on disk')
        self._offset += length
        return data

    def tell(self) -> int:
        return self._offset


class _Salvage:
    """The complete records of a damaged file, copied into a new file as they are read.

    Each top-level record is taken whole or not at all: a chunk only once its content is
    decompressed, its CRC checked and every record in it is consistent.
    """

    def __init__(self, tmp: Path) -> None:
        self.content = _Content()
        self.used = 0  # bytes of the damaged file that were used
        self._tmp = tmp
        self._writer: McapFileWriter | None = None
        self._declared: list[Schema | Channel] = []  # written with the first chunk

    def run(self, raw: BinaryIO, size: int, file: Path) -> str:
        """Copy what can be used of ``raw`` (``size`` bytes); return why the copy stopped."""
        head = raw.read(len(MAGIC))
        if head != MAGIC:
            if len(head) < len(MAGIC) and MAGIC.startswith(head):
                return 'file cut off inside the magic'
            raise BagError(f'{file}: not an MCAP file (bad magic at offset 0)')
        self.used = len(MAGIC)
        stream = _Exact(raw, size)
        reader = StreamReader(stream, skip_magic=True, emit_chunks=True,  # type: ignore[arg-type]
                              validate_crcs=True)
        try:
            for record in reader.records:
                if isinstance(record, (DataEnd, Footer)):
                    self.used = stream.tell()
                    return (f'data section ends at offset {self.used} but the summary is '
                            'unreadable')
                self._take(record)
                self.used = stream.tell()
        except _Damaged as exc:
            return f'record at offset {self.used} cut off ({exc})'
        except Exception as exc:  # noqa: BLE001 - struct, CRC, zstd, lz4 or record errors
            return f'bad record after offset {self.used}: {exc}'
        return 'end of file'

    def _take(self, record: object) -> None:
        inner = breakup_chunk(record, validate_crc=True) if isinstance(record, Chunk) else [record]
        trial = _Content(dict(self.content.schemas), dict(self.content.channels),
                         dict(self.content.counts), self.content.start_ns, self.content.end_ns)
        declared: list[Schema | Channel] = []
        batch: list[tuple[int, int, bytes]] = []
        for r in inner:
            if isinstance(r, Schema):
                trial.schemas[r.id] = (r.name, r.encoding, r.data)
                declared.append(r)
            elif isinstance(r, Channel):
                trial.channels[r.id] = _Channel(r.schema_id, r.topic, r.message_encoding,
                                                dict(r.metadata))
                trial.counts.setdefault(r.id, 0)
                declared.append(r)
            elif isinstance(r, Message):
                if r.channel_id not in trial.channels:
                    raise ValueError(f'message on undeclared channel {r.channel_id}')
                trial.counts[r.channel_id] += 1
                trial.start_ns = min(trial.start_ns, r.log_time)
                trial.end_ns = max(trial.end_ns, r.log_time)
                batch.append((r.channel_id, r.log_time, r.data))
        self.content = trial
        self._declared += declared
        if isinstance(record, Chunk) and self._writer is None:  # the first chunk's compression
            self._writer = McapFileWriter(self._tmp, compression=record.compression or 'none',
                                          chunk_duration_ns=0)
        if self._writer is not None:
            self._declare(self._writer)
            self._writer.write_batch(batch)

    def _declare(self, writer: McapFileWriter) -> None:
        for r in self._declared:
            if isinstance(r, Schema):
                writer.add_schema(r.id, r.name, r.encoding, r.data)
            else:
                writer.add_channel(r.id, r.schema_id, r.topic, r.message_encoding, r.metadata)
        self._declared.clear()

    def close(self) -> None:
        """Finish the new file (summary and footer)."""
        if self._writer is None:  # no chunk: schemas and channels only, if any
            self._writer = McapFileWriter(self._tmp, chunk_duration_ns=0)
        self._declare(self._writer)
        self._writer.close()

    def abort(self) -> None:
        """Close the new file as it is."""
        if self._writer is not None:
            self._writer.abort()
