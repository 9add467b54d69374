"""Fixtures of the node tests: a ROS domain of each test's own, claimed by a lock, and the
test's listener on DDS."""
from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))  # rostest and the helpers beside it: test/nodes is no package
from ros_domains import claim_domain  # noqa: E402  (test/ is no package)

#: the last test's domain lock, released once the next test holds its own: two tests in a
#: row never share a domain, so nothing a test left behind is heard by the next one
_previous: list[IO[str]] = []


@pytest.fixture
def domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A ROS domain of this test's own, inherited by every process the test starts.

    Claimed with the lock of ``test/ros_domains.py``, as the session's domain is: no other
    test run on this machine uses it meanwhile (a pid modulo could give two runs the same
    domain, and one run's bag then held the other's samples).
    """
    value, lock = claim_domain()
    while _previous:
        _previous.pop().close()
    _previous.append(lock)
    monkeypatch.setenv('ROS_DOMAIN_ID', str(value))
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    return value


@pytest.fixture
def listener(request: pytest.FixtureRequest) -> Iterator[Any]:
    """The test's side of DDS: a ``rostest.Listener`` (a fresh rclpy Context) named after the
    test module, closed after the test. A test module that wants its own domain for it
    requests ``domain`` first (``pytest.mark.usefixtures('domain')``)."""
    from rostest import Listener  # here, not above: only the tests that listen import rclpy

    node = Listener(f'{request.path.stem}_listener')
    try:
        yield node
    finally:
        node.close()
