"""Cut serialized messages to their exact CDR length: a copy of a bag that every reader reads.

Bags recorded by earlier versions of this package hold ``/<method>/identified_torque`` and
``/<method>/external_torque`` JointState messages with 8 bytes past their data:
``rclpy.serialization.serialize_message`` counts the 8-byte alignment of an empty float64
sequence that the data never take, and the identifier published those bytes as they were.
rosbags refuses a message with more than 3 bytes after its data (``CDR message size
mismatch``); rclpy, ``mcap_ros2`` and this package's readers take it.

:func:`trim_bag` writes a copy of a bag (rosbag2 directory with MCAP or sqlite3 storage, or a
bare ``.mcap``/``.db3`` file) in which

- every little-endian ``sensor_msgs/msg/JointState`` ends where its data end
  (:attr:`~scara_ident_ros.bag.cdr.JointStateSpans.end`; a JointState's data always end
  4-aligned, so nothing a middleware pads is cut);
- a message of any other type (or a big-endian JointState) with more than the 3 bytes of
  padding rosbags allows after its data is cut to its data, its length found by rosbags'
  decoder with the bag's own message definitions;
- everything else is as it was: ``metadata.yaml`` and every other file byte for byte, and in
  each MCAP file the header, schemas, channels (QoS and type hash in their metadata), log and
  publish times, sequence numbers, metadata and attachment records, chunk boundaries and
  compression. A message that cannot be decoded is copied as it is and counted.

The input is never changed; the copy is written beside its destination and renamed into
place once complete. :func:`exact_joint_state` is the same cut for one message (the player
publishes old bags' messages through it).
"""
from __future__ import annotations

import shutil
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scara_ident_ros.bag.cdr import split_joint_state
from scara_ident_ros.bag.errors import BagError

__all__ = ['JOINT_STATE', 'ROSBAGS_SLACK', 'TopicTrim', 'TrimReport', 'exact_joint_state',
           'trim_bag']

JOINT_STATE = 'sensor_msgs/msg/JointState'
#: Bytes after a message's data that rosbags still accepts (CDR padding to 4 bytes).
ROSBAGS_SLACK = 3
_HEADER = 4  # bytes of the CDR encapsulation header


def exact_joint_state(raw: bytes) -> bytes:
    """``raw`` (a serialized little-endian JointState) without the bytes after its data;
    ``raw`` itself if it has none or is not such a message."""
    try:
        end = split_joint_state(raw).end
    except ValueError:
        return raw
    return raw[:end] if end < len(raw) else raw


@dataclass
class TopicTrim:
    """What :func:`trim_bag` did to one topic.

    Attributes
    ----------
    msgtype : str
    messages : int
        Messages copied.
    trimmed : int
        Messages cut to their exact length.
    bytes_removed : int
        Bytes cut, all messages of the topic.
    undecodable : int
        Messages whose length could not be found (copied as they are).
    """

    msgtype: str
    messages: int = 0
    trimmed: int = 0
    bytes_removed: int = 0
    undecodable: int = 0


@dataclass(frozen=True)
class TrimReport:
    """The outcome of :func:`trim_bag`: the copy and, per topic, what was cut."""

    source: Path
    path: Path
    topics: dict[str, TopicTrim] = field(default_factory=dict)

    @property
    def trimmed(self) -> int:
        """Messages cut, all topics."""
        return sum(t.trimmed for t in self.topics.values())

    @property
    def message_count(self) -> int:
        """Messages copied, all topics."""
        return sum(t.messages for t in self.topics.values())

    def summary(self) -> str:
        """One line for the copy, one per topic, for a terminal."""
        lines = [f'{self.path}: copy of {self.source}, {self.message_count} messages, '
                 f'{self.trimmed} cut to their exact CDR length']
        for name, t in sorted(self.topics.items()):
            extra = f', {t.undecodable} undecodable (copied as they are)' if t.undecodable \
                else ''
            lines.append(f'  {name} ({t.msgtype}): {t.trimmed} of {t.messages} cut, '
                         f'{t.bytes_removed} bytes{extra}')
        return '\n'.join(lines)


class _Cutter:
    """The exact length of the messages of each type, with the bag's own definitions."""

    def __init__(self, source: Path) -> None:
        self._source = source
        self._store: Any = None

    def _typestore(self) -> Any:
        if self._store is None:
            from rosbags.highlevel import AnyReader
            from rosbags.typesys import Stores, get_typestore

            try:
                with AnyReader([self._source],
                               default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
                    self._store = reader.typestore
            except Exception as exc:  # noqa: BLE001 - rosbags raises its own per storage
                raise BagError(f'{self._source}: cannot read the message definitions: '
                               f'{exc}') from exc
        return self._store

    def cut(self, msgtype: str, raw: bytes, trim: TopicTrim) -> bytes:
        """``raw`` cut to its data (see the module docstring); counted in ``trim``."""
        trim.messages += 1
        end = None
        if msgtype == JOINT_STATE:
            try:
                end = split_joint_state(raw).end
            except ValueError:
                end = None
        if end is None:
            end = self._generic_end(msgtype, raw)
            if end is None:
                trim.undecodable += 1
                return raw
            if len(raw) - end <= ROSBAGS_SLACK:
                return raw
        if end >= len(raw):
            return raw
        trim.trimmed += 1
        trim.bytes_removed += len(raw) - end
        return raw[:end]

    def _generic_end(self, msgtype: str, raw: bytes) -> int | None:
        if len(raw) < _HEADER or raw[0] != 0 or raw[1] not in (0, 1):
            return None
        store = self._typestore()
        try:
            msgdef = store.get_msgdef(msgtype)
            func = msgdef.deserialize_cdr_le if raw[1] else msgdef.deserialize_cdr_be
            _, pos = func(memoryview(raw)[_HEADER:], 0, msgdef.cls, store)
        except Exception:  # noqa: BLE001 - unknown type, struct or decode errors
            return None
        end = _HEADER + int(pos)
        return end if end <= len(raw) else None


def trim_bag(source: str | Path, destination: str | Path) -> TrimReport:
    """Write a copy of ``source`` at ``destination`` with every message cut to its exact
    CDR length (module docstring).

    Raises
    ------
    BagError
        If ``source`` is not a readable rosbag2 bag or storage file (a bag left by a killed
        recorder: ``scara-ident recover`` it first), or ``destination`` exists.
    """
    from scara_ident_ros.bag.reader import open_bag

    source, destination = Path(source), Path(destination)
    if destination.exists() or destination.is_symlink():
        raise BagError(f'{destination} exists already, not overwriting')
    with open_bag(source):  # the checks of every reader: layout, magic, metadata
        pass
    partial = destination.with_name(destination.name + '.partial')
    if partial.exists():
        raise BagError(f'{partial} exists (an interrupted copy?): remove it first')
    cutter = _Cutter(source)
    report = TrimReport(source, destination)
    try:
        if source.is_dir():
            partial.mkdir(parents=True)
            # storage files last: a sqlite3 file is changed after its -wal/-shm are beside it
            for item in sorted(source.iterdir(),
                               key=lambda p: (p.suffix in ('.mcap', '.db3'), p.name)):
                _copy_file(item, partial / item.name, cutter, report)
        else:
            partial.parent.mkdir(parents=True, exist_ok=True)
            _copy_file(source, partial, cutter, report)
        partial.rename(destination)
    except BaseException:
        if partial.is_dir():
            shutil.rmtree(partial, ignore_errors=True)
        else:
            partial.unlink(missing_ok=True)
        raise
    return report


def _copy_file(item: Path, target: Path, cutter: _Cutter, report: TrimReport) -> None:
    if item.is_dir():
        shutil.copytree(item, target)
    elif item.suffix == '.mcap':
        _copy_mcap(item, target, cutter, report)
    elif item.suffix == '.db3':
        _copy_sqlite(item, target, cutter, report)
    else:
        shutil.copy2(item, target)


def _topic(report: TrimReport, topic: str, msgtype: str) -> TopicTrim:
    known = report.topics.get(topic)
    if known is None:
        known = report.topics[topic] = TopicTrim(msgtype)
    return known


def _copy_mcap(file: Path, target: Path, cutter: _Cutter, report: TrimReport) -> None:
    """Copy one MCAP file record by record, cutting message data; chunks stay chunks."""
    from mcap.records import (Attachment, Channel, Chunk, DataEnd, Footer, Header, Message,
                              Metadata, Schema)
    from mcap.stream_reader import StreamReader, breakup_chunk
    from mcap.writer import CompressionType, Writer

    compressions = {'': CompressionType.NONE, 'none': CompressionType.NONE,
                    'zstd': CompressionType.ZSTD, 'lz4': CompressionType.LZ4}
    schemas: dict[int, tuple[int, str]] = {0: (0, '')}  # input id -> (output id, name)
    channels: dict[int, tuple[int, str, str]] = {}  # input id -> (output id, topic, type)
    header = Header('', '')
    waiting: list[object] = []  # records before the first chunk or message
    writer: Writer | None = None

    def take(writer: Writer, record: object) -> None:
        if isinstance(record, Schema):
            schemas[record.id] = (writer.register_schema(record.name, record.encoding,
                                                         record.data), record.name)
        elif isinstance(record, Channel):
            schema_id, msgtype = schemas.get(record.schema_id, (0, ''))
            channels[record.id] = (writer.register_channel(
                record.topic, record.message_encoding, schema_id, dict(record.metadata)),
                record.topic, msgtype)
        elif isinstance(record, Message):
            channel_id, topic, msgtype = channels[record.channel_id]
            data = cutter.cut(msgtype, record.data, _topic(report, topic, msgtype))
            writer.add_message(channel_id, record.log_time, data, record.publish_time,
                               record.sequence)
        elif isinstance(record, Chunk):
            for inner in breakup_chunk(record, validate_crc=True):
                take(writer, inner)
            writer.flush()  # one chunk out for each chunk in
        elif isinstance(record, Metadata):
            writer.add_metadata(record.name, dict(record.metadata))
        elif isinstance(record, Attachment):
            writer.add_attachment(record.create_time, record.log_time, record.name,
                                  record.media_type, record.data)

    with file.open('rb') as stream, target.open('xb') as out:
        reader = StreamReader(stream, emit_chunks=True,
                              validate_crcs=True)
        for record in reader.records:
            if isinstance(record, (DataEnd, Footer)):  # the summary repeats what came before
                break
            if isinstance(record, Header):
                header = record
                continue
            if writer is None:
                if not isinstance(record, (Chunk, Message)):
                    waiting.append(record)
                    continue
                compression = record.compression if isinstance(record, Chunk) else ''
                if compression not in compressions:
                    raise BagError(f'{file}: unknown chunk compression {compression!r}')
                writer = Writer(out, chunk_size=1 << 62, compression=compressions[compression],
                                use_chunking=isinstance(record, Chunk))
                writer.start(header.profile, header.library)
                for early in waiting:
                    take(writer, early)
            take(writer, record)
        if writer is None:  # no message at all
            writer = Writer(out, compression=CompressionType.NONE)
            writer.start(header.profile, header.library)
            for early in waiting:
                take(writer, early)
        writer.finish()


def _copy_sqlite(file: Path, target: Path, cutter: _Cutter, report: TrimReport) -> None:
    """Copy a rosbag2 sqlite3 file, then cut the data of its messages in the copy."""
    shutil.copy2(file, target)
    connection = sqlite3.connect(target)
    try:
        topics = {row[0]: (row[1], row[2]) for row in
                  connection.execute('SELECT id, name, type FROM topics')}
        cut: list[tuple[bytes, int]] = []
        for row_id, topic_id, data in connection.execute(
                'SELECT id, topic_id, data FROM messages ORDER BY id').fetchall():
            topic, msgtype = topics[topic_id]
            raw = bytes(data)
            new = cutter.cut(msgtype, raw, _topic(report, topic, msgtype))
            if len(new) != len(raw):
                cut.append((new, row_id))
        connection.executemany('UPDATE messages SET data = ? WHERE id = ?', cut)
        connection.commit()
    except sqlite3.Error as exc:
        raise BagError(f'{file}: cannot copy the sqlite3 storage: {exc}') from exc
    finally:
        connection.close()
