"""Waiting for a graph's own subscribers (`subscribers_heard`): a count, and the nodes named."""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any

from scara_ident_ros.nodes.subscribers import subscribers_heard


class Graph:
    """Stands for a node and its publisher: ``matched`` subscriptions matched, ``shown`` the
    (namespace, name) of each subscription the graph shows."""

    def __init__(self, matched: int, shown: list[tuple[str, str]]) -> None:
        self.matched = matched
        self.shown = shown
        self.topic_name = '/joint_states'

    def get_subscription_count(self) -> int:
        return self.matched

    def get_subscriptions_info_by_topic(self, topic: str) -> list[Any]:
        assert topic == self.topic_name
        return [SimpleNamespace(node_namespace=ns, node_name=name) for ns, name in self.shown]


def heard(graph: Graph, count: int, names: tuple[str, ...] = ()) -> bool:
    return subscribers_heard(graph, graph, count, names)  # type: ignore[arg-type]


def test_a_count_alone_is_met_by_any_subscribers() -> None:
    others = Graph(2, [('/', 'all_recorder'), ('/probe', 'identifier')])
    assert heard(others, 2)
    assert not heard(Graph(1, [('/', 'recorder')]), 2)


def test_named_nodes_must_be_among_the_subscribers() -> None:
    names = ('/recorder', '/identifier')
    others = Graph(2, [('/', 'all_recorder'), ('/probe', 'identifier')])
    assert not heard(others, 2, names)  # two subscribers, neither of them the run's
    one = Graph(3, [('/', 'all_recorder'), ('/probe', 'identifier'), ('/', 'recorder')])
    assert not heard(one, 2, names)
    both = Graph(4, [('/', 'all_recorder'), ('/probe', 'identifier'), ('/', 'recorder'),
                     ('/', 'identifier')])
    assert heard(both, 2, names)


def test_every_subscription_the_graph_shows_must_be_matched() -> None:
    """Shown by the graph but not matched yet by the publisher: its first sample would be
    lost to that subscriber."""
    shown = [('/', 'recorder'), ('/', 'identifier'), ('/', 'all_recorder')]
    assert not heard(Graph(2, shown), 2, ('/recorder', '/identifier'))
    assert heard(Graph(3, shown), 2, ('/recorder', '/identifier'))
