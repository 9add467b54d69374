"""The three readers a user decodes this project's messages with, each as it is used.

- rosbags: ``Typestore.deserialize_cdr`` (what ``AnyReader.deserialize`` calls), which
  refuses more than 3 bytes after a message's data (``CDR message size mismatch``);
- mcap-ros2-support: ``mcap_ros2.decoder.DecoderFactory``, from the ``ros2msg`` schema
  a bag stores (:func:`scara_ident_ros.bag.typedefs.message_definition`);
- rclpy: ``rclpy.serialization.deserialize_message`` with the generated message class.

Each returns the message in its own form; :func:`joint_state_fields` turns a JointState
of any of them into the same plain values, so the three can be compared.
"""
from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import deserialize_message
from rosbags.typesys import Stores, get_typestore

from scara_ident_ros.bag.message_class import message_class
from scara_ident_ros.bag.typedefs import message_definition

__all__ = ['READERS', 'joint_state_fields']

STORE = get_typestore(Stores.ROS2_JAZZY)
_MCAP = DecoderFactory()


@cache
def _mcap_decoder(msgtype: str) -> Callable[[bytes], Any]:
    definition = message_definition(msgtype)
    schema = Schema(id=len(_MCAP._decoders) + 1, name=msgtype, encoding='ros2msg',
                    data=definition.text.encode())
    decoder = _MCAP.decoder_for('cdr', schema)
    assert decoder is not None, msgtype
    return decoder


def _rosbags(data: bytes, msgtype: str) -> Any:
    return STORE.deserialize_cdr(data, msgtype)


def _mcap_ros2(data: bytes, msgtype: str) -> Any:
    return _mcap_decoder(msgtype)(data)


def _rclpy(data: bytes, msgtype: str) -> Any:
    cls = message_class(msgtype)
    assert cls is not None, msgtype
    return deserialize_message(data, cls)


#: reader name -> ``decode(data, msgtype)``
READERS: dict[str, Callable[[bytes, str], Any]] = {
    'rosbags': _rosbags, 'mcap_ros2': _mcap_ros2, 'rclpy': _rclpy}


def joint_state_fields(msg: Any) -> dict[str, Any]:
    """A JointState of any of the three readers as plain values: stamp (ns), frame, names
    and the three arrays as lists of float."""
    return {'stamp_ns': msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec,
            'frame_id': msg.header.frame_id, 'name': list(msg.name),
            **{key: [float(v) for v in getattr(msg, key)]
               for key in ('position', 'velocity', 'effort')}}
