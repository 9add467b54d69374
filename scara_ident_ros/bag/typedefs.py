"""Message definitions and type hashes for the types a recorder meets on the graph.

A rosbag2 MCAP file stores, per message type, its definition (``ros2msg`` text with
the definitions it depends on, as ``rosbag2`` writes it) and a RIHS01 type hash. Both
come from rosbags' Jazzy type store, which knows the standard interfaces; other types
are looked up as ``.msg`` files in the ``share/<package>/msg/`` directories of
``AMENT_PREFIX_PATH`` and of the Python prefix (where the PyPI wheels install them).
The hash is the one rosbags computes from the same definition, so readers that check
it (``rosbags.highlevel.AnyReader``) accept the bag. A type found nowhere is recorded
with an empty definition: its messages are kept as bytes, only not decodable.
"""
from __future__ import annotations

import os
import sys
from functools import cache
from pathlib import Path
from typing import Any, NamedTuple

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

__all__ = ['TypeDefinition', 'message_definition']


class TypeDefinition(NamedTuple):
    """What a bag stores about a message type.

    Attributes
    ----------
    text : str
        The definition, ``ros2msg`` syntax with dependencies; '' if unknown.
    encoding : str
        MCAP schema encoding: ``'ros2msg'``.
    type_hash : str
        ``'RIHS01_<hex>'``; '' if unknown.
    """

    text: str
    encoding: str
    type_hash: str


@cache
def _store() -> Typestore:
    return get_typestore(Stores.ROS2_JAZZY)


def _share_dirs() -> list[Path]:
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    prefixes.append(sys.prefix)
    return [Path(prefix) / 'share' for prefix in prefixes]


def _msg_file(msgtype: str) -> Path | None:
    package, _, name = msgtype.partition('/msg/')
    for share in _share_dirs():
        candidate = share / package / 'msg' / f'{name}.msg'
        if candidate.is_file():
            return candidate
    return None


def _referenced(desc: Any) -> list[str]:
    """Type names a rosbags field description refers to (NAME nodes, nested)."""
    kind, rest = desc
    if getattr(kind, 'name', '') == 'NAME':
        return [rest]
    if isinstance(rest, tuple) and rest and isinstance(rest[0], tuple):
        return _referenced(rest[0])
    return []


def _register_from_share(store: Typestore, msgtype: str) -> bool:
    """Register ``msgtype`` and the types it needs from ``.msg`` files; False if missing."""
    pending = [msgtype]
    found: dict[str, Any] = {}
    while pending:
        name = pending.pop()
        if name in found or name in store.fielddefs:
            continue
        path = _msg_file(name)
        if path is None:
            return False
        types = get_types_from_msg(path.read_text(), name)
        found.update(types)
        for _, fields in types.values():
            for _, desc in fields:
                pending.extend(_referenced(desc))
    store.register(found)
    return True


@cache
def message_definition(msgtype: str) -> TypeDefinition:
    """Return the definition and hash to record for ``msgtype`` (e.g. 'std_msgs/msg/Bool')."""
    store = _store()
    try:
        if msgtype not in store.fielddefs and not _register_from_share(store, msgtype):
            return TypeDefinition('', 'ros2msg', '')
        text, _ = store.generate_msgdef(msgtype, ros_version=2)
        return TypeDefinition(text, 'ros2msg', store.hash_rihs01(msgtype))
    except Exception:  # noqa: BLE001 - a .msg file rosbags cannot parse: record raw bytes
        return TypeDefinition('', 'ros2msg', '')
