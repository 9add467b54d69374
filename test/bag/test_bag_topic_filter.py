"""Topic names and glob patterns select what the recorder records and the player plays."""
from __future__ import annotations

import pytest

from scara_ident_ros.bag import TopicFilter

TOPICS = ['/joint_states', '/identified_torque', '/ffmw/identified_torque',
          '/ffw/identification_mse', '/a/b/identified_torque', '/rosout', '/_hidden/x']


def test_names_and_one_level_globs() -> None:
    selected = TopicFilter(['joint_states', '/*/identified_torque']).select(TOPICS)
    assert selected == ['/joint_states', '/ffmw/identified_torque']


def test_double_star_crosses_namespaces() -> None:
    assert TopicFilter(['/**/identified_torque']).select(TOPICS) == [
        '/ffmw/identified_torque', '/a/b/identified_torque']
    assert TopicFilter(['/ff?/*']).select(TOPICS) == ['/ffw/identification_mse']


def test_all_topics_except_hidden_ones() -> None:
    assert TopicFilter([], all_topics=True).select(TOPICS) == TOPICS[:-1]


def test_empty_pattern_is_refused() -> None:
    with pytest.raises(ValueError, match='empty topic'):
        TopicFilter(['/a', ' '])
