"""Whether a publisher's own subscribers are there: a count, and the nodes named.

A node started by a graph (``scara-ident run``) waits, before its first sample, for the
graph's subscribers: the simulator for the recorder and the identifier, the identifier for
the recorder on its outputs. A count alone (``wait_for_subscribers``) is met by any
subscriber on the ROS domain: beside a second recorder and identifier subscribed before the
run, the simulator started while the run's identifier was still starting, and that
identifier predicted none of the 5000 samples (``test/nodes/test_recorded_bag_readers.py``;
a recorder of every topic subscribes as soon as a publisher appears, so counting those
already there does not help). ``wait_for_nodes`` names them: the wait ends once each named
node (its fully qualified name, e.g. ``/identifier``) has a subscription on the topic and
the publisher has matched every subscription the graph shows, so that none of them misses
the first sample. A subscription the publisher cannot match (a QoS it does not offer, e.g.
transient local on the simulator's volatile ``/joint_states``) holds the wait until its
``wait_timeout``, after which the node starts anyway and says so.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from scara_ident_ros.parameter_spec import ParamSpec

if TYPE_CHECKING:
    from rclpy.node import Node
    from rclpy.publisher import Publisher

__all__ = ['WAIT_FOR_NODES', 'subscribers_heard']

#: The parameter of the nodes that wait (simulator, identifier).
WAIT_FOR_NODES = ParamSpec(
    'wait_for_nodes', [], 'Before the first sample, wait (with wait_for_subscribers, up to '
    'wait_timeout) until each of these nodes (fully qualified names, e.g. /recorder) '
    'subscribes: other subscribers on the domain do not count as them', items=str)


def subscribers_heard(node: Node, publisher: Publisher, count: int,
                      names: Sequence[str] = ()) -> bool:
    """Whether ``publisher`` has ``count`` matched subscribers, among them one of each node
    named in ``names``, and has matched every subscription the graph shows.

    Parameters
    ----------
    node : Node
        The node of ``publisher`` (its view of the graph).
    publisher : Publisher
        The publisher whose subscribers are waited for.
    count : int
        Least number of matched subscribers.
    names : sequence of str
        Fully qualified node names (``/ns/name``) that must subscribe.
    """
    matched = publisher.get_subscription_count()
    if matched < count:
        return False
    if not names:
        return True
    infos = node.get_subscriptions_info_by_topic(publisher.topic_name)
    subscribed = {f"{info.node_namespace.rstrip('/')}/{info.node_name}" for info in infos}
    return set(names) <= subscribed and matched >= len(infos)
