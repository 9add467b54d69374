"""The ``metadata.yaml`` of a rosbag2 bag (format version 9, as ROS 2 Jazzy writes it).

:func:`write_metadata` is used when a recording is closed and when one is recovered; it
describes every storage file of the bag (one per split) and every topic with its type,
message count, offered QoS profiles and type hash, so ``ros2 bag info``, rosbags'
``Reader``/``AnyReader`` and this package's :func:`~scara_ident_ros.bag.open_bag` read
the files as one bag.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from rosbags.interfaces import Qos

from scara_ident_ros.bag.qos import dump_offered_qos

__all__ = ['FileSummary', 'METADATA_FILE', 'TopicSummary', 'bag_metadata', 'write_metadata']

METADATA_FILE = 'metadata.yaml'
VERSION = 9


@dataclass(frozen=True)
class FileSummary:
    """One storage file: name (relative to the bag), time range (ns) and message count."""

    name: str
    start_ns: int
    end_ns: int
    message_count: int


@dataclass(frozen=True)
class TopicSummary:
    """One topic: name, type, serialization, offered QoS, type hash and message count."""

    name: str
    msgtype: str
    message_count: int
    offered_qos: Sequence[Qos] = field(default_factory=tuple)
    type_hash: str = ''
    serialization_format: str = 'cdr'


def bag_metadata(files: Sequence[FileSummary], topics: Sequence[TopicSummary], *,
                 storage: str = 'mcap', ros_distro: str = 'jazzy',
                 custom_data: dict[str, str] | None = None) -> dict[str, Any]:
    """Return the ``metadata.yaml`` document (``{'rosbag2_bagfile_information': ...}``).

    Compression inside MCAP chunks is a property of the storage files, so
    ``compression_format`` and ``compression_mode`` are empty, as with rosbag2's MCAP
    compression presets.
    """
    used = [f for f in files if f.message_count]
    start = min((f.start_ns for f in used), default=0)
    end = max((f.end_ns for f in used), default=0)
    return {'rosbag2_bagfile_information': {
        'version': VERSION,
        'storage_identifier': storage,
        'relative_file_paths': [f.name for f in files],
        'duration': {'nanoseconds': end - start},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': sum(f.message_count for f in files),
        'topics_with_message_count': [
            {'topic_metadata': {
                'name': t.name,
                'type': t.msgtype,
                'serialization_format': t.serialization_format,
                'offered_qos_profiles': dump_offered_qos(t.offered_qos),
                'type_description_hash': t.type_hash,
            }, 'message_count': t.message_count}
            for t in topics],
        'compression_format': '',
        'compression_mode': '',
        'files': [
            {'path': f.name,
             'starting_time': {'nanoseconds_since_epoch': f.start_ns if f.message_count else 0},
             'duration': {'nanoseconds': f.end_ns - f.start_ns if f.message_count else 0},
             'message_count': f.message_count}
            for f in files],
        'custom_data': dict(custom_data or {}),
        'ros_distro': ros_distro,
    }}


def write_metadata(bag: Path, files: Sequence[FileSummary], topics: Sequence[TopicSummary],
                   **options: Any) -> Path:
    """Write ``bag/metadata.yaml`` atomically (temporary file, then rename); return its path."""
    path = bag / METADATA_FILE
    tmp = path.with_suffix('.yaml.tmp')
    tmp.write_text(yaml.safe_dump(bag_metadata(files, topics, **options), sort_keys=False))
    tmp.replace(path)
    return path
