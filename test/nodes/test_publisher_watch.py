"""Backward stamps: the trace of interleaved publishers that `PublisherWatch` reports."""
from __future__ import annotations

import pytest

from scara_ident_ros.nodes.publisher_watch import INTERLEAVED_STEPS, StampOrder

pytestmark = pytest.mark.ros

MS = 1_000_000  # ns


def test_one_publisher_never_goes_back_and_a_restart_goes_back_once() -> None:
    order = StampOrder()
    for k in [*range(100), *range(50)]:  # a simulator restarted at 0
        order.observe(k * MS)
    assert order.backward == 1
    assert order.since_last_look() == 1 < INTERLEAVED_STEPS
    assert order.since_last_look() == 0


def test_two_interleaved_publishers_go_back_every_other_sample() -> None:
    order = StampOrder()
    for k in range(100):
        order.observe(k * MS)  # the first simulator
        order.observe(5_000 * MS + k * MS)  # the second, started 5 s later
    assert order.since_last_look() == 99 >= INTERLEAVED_STEPS
