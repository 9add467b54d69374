"""QoS profiles as recorded in bags (rosbags' :class:`~rosbags.interfaces.Qos`), without rclpy.

A bag stores, per topic, the QoS profiles its publishers *offered*. The recorder reads
them from the graph (``Node.get_publishers_info_by_topic``; :func:`qos_from_profile`
converts an ``rclpy.qos.QoSProfile`` by duck typing, so this module never imports
rclpy) and the player offers them back. :func:`adapt_to_offers` is rosbag2's rule for
a subscription that must match every publisher (and for a player that must look like
them): reliable only if all offer reliable, transient-local only if all offer it.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness,
                                QosReliability, QosTime)
from rosbags.rosbag2.metadata import dump_qos_v9, parse_qos

__all__ = ['AdaptedQos', 'adapt_to_offers', 'dump_offered_qos', 'parse_offered_qos',
           'qos_from_profile']


class AdaptedQos(NamedTuple):
    """The policies a recorder subscription (or a player publisher) should use."""

    reliable: bool
    transient_local: bool


def _time(duration: Any) -> QosTime:
    nanoseconds = int(getattr(duration, 'nanoseconds', duration))
    sec, nsec = divmod(nanoseconds, 1_000_000_000)
    return QosTime(sec, nsec)


def qos_from_profile(profile: Any) -> Qos:
    """Convert an ``rclpy.qos.QoSProfile`` (duck-typed) to rosbags' ``Qos``.

    The rclpy and rmw enum values are the ones rosbags uses (``KEEP_LAST`` = 1,
    ``RELIABLE`` = 1, ``TRANSIENT_LOCAL`` = 1, ...); durations become (sec, nsec).
    """
    def value(policy: Any) -> int:
        return int(getattr(policy, 'value', policy))

    return Qos(
        history=QosHistory(value(profile.history)),
        depth=int(profile.depth),
        reliability=QosReliability(value(profile.reliability)),
        durability=QosDurability(value(profile.durability)),
        deadline=_time(profile.deadline),
        lifespan=_time(profile.lifespan),
        liveliness=QosLiveliness(value(profile.liveliness)),
        liveliness_lease_duration=_time(profile.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions),
    )


def adapt_to_offers(offers: Sequence[Qos], *, default_reliable: bool = True) -> AdaptedQos:
    """rosbag2's adaptation: the policies that match every offered profile.

    Parameters
    ----------
    offers : sequence of Qos
        What the publishers offer (or offered, in a bag).
    default_reliable : bool
        Reliability when nothing is known (no offers).
    """
    if not offers:
        return AdaptedQos(default_reliable, False)
    reliable = all(q.reliability == QosReliability.RELIABLE for q in offers)
    transient = all(q.durability == QosDurability.TRANSIENT_LOCAL for q in offers)
    return AdaptedQos(reliable, transient)


def dump_offered_qos(offers: Sequence[Qos]) -> list[dict[str, Any]]:
    """The ``offered_qos_profiles`` of rosbag2 metadata version 9 (a list of mappings)."""
    return [dict(item) for item in dump_qos_v9(list(offers))]


def parse_offered_qos(text: str | list[Any]) -> list[Qos]:
    """Parse ``offered_qos_profiles`` as found in metadata or MCAP channel metadata."""
    return parse_qos(text)
