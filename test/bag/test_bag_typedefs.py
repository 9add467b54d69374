"""Definitions and hashes for standard types and for types found only as .msg files."""
from __future__ import annotations

from pathlib import Path

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from scara_ident_ros.bag import typedefs


def test_standard_type_matches_rosbags() -> None:
    store = get_typestore(Stores.ROS2_JAZZY)
    definition = typedefs.message_definition('sensor_msgs/msg/JointState')
    assert definition.text == store.generate_msgdef('sensor_msgs/msg/JointState',
                                                    ros_version=2)[0]
    assert definition.type_hash == store.hash_rihs01('sensor_msgs/msg/JointState')
    assert definition.encoding == 'ros2msg'


def test_type_from_msg_files_with_a_dependency(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    msg = tmp_path / 'share' / 'my_pkg' / 'msg'
    msg.mkdir(parents=True)
    (msg / 'Sample.msg').write_text('std_msgs/Header header\nmy_pkg/Pair[] pairs\n')
    (msg / 'Pair.msg').write_text('float64 a\nfloat64 b\n')
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    definition = typedefs.message_definition('my_pkg/msg/Sample')
    assert 'MSG: my_pkg/Pair' in definition.text
    assert 'MSG: std_msgs/Header' in definition.text
    # The hash a reader (rosbags' AnyReader) recomputes from the recorded text:
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(definition.text, 'my_pkg/msg/Sample'))
    assert store.hash_rihs01('my_pkg/msg/Sample') == definition.type_hash


def test_unknown_type_is_recorded_without_definition() -> None:
    assert typedefs.message_definition('nowhere_pkg/msg/Nothing') == ('', 'ros2msg', '')
