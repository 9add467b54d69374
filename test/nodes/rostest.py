"""Small helpers for node tests: a node in its own process, a listener in a fresh Context.

A node under test runs as ``python -m <module> --ros-args ...`` in a child process
(:class:`NodeProcess`, a context manager that always kills the child on the way out),
its stdout and stderr going to temporary files so a chatty child never blocks on a
full pipe. The test listens with a :class:`Listener`: its own ``rclpy`` Context,
node and executor, driven by ``spin_once`` and shut down by ``close()``, so nothing
is left behind in the default context between tests.

The children inherit ``os.environ`` (``ROS_DOMAIN_ID`` chosen by ``test/conftest.py``),
with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` forced unless already set.

Importing: pytest runs with ``--import-mode=importlib``, so ``test/nodes/conftest.py`` puts
this directory on ``sys.path`` for the test modules' ``import rostest``.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rcl_interfaces.srv import DescribeParameters, SetParameters
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy

__all__ = ['NodeOutput', 'NodeProcess', 'Listener', 'reliable']

STOP_TIMEOUT = 60.0  # seconds a node gets to exit after a signal (the machine is shared)
SERVICE_TIMEOUT = 60.0  # seconds for a service to appear, and then to answer


def reliable(depth: int = 1000) -> QoSProfile:
    """A reliable, keep-last QoS of ``depth`` (default: a second of history at 1 kHz)."""
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)


@dataclass(frozen=True)
class NodeOutput:
    """What a finished node process left: exit status and its output."""

    returncode: int
    stdout: str
    stderr: str


class NodeProcess:
    """Run ``python -m module --ros-args *ros_args`` as a child process.

    Use as a context manager: the child is killed on exit if it still runs, so a
    failing assertion never leaves a node publishing in the background.

    Parameters
    ----------
    module : str
        Module with a ``main()``, e.g. ``'scara_ident_ros.nodes.scara_sim'``.
    ros_args : sequence of str
        Arguments after ``--ros-args`` (``-p name:=value``, ``--params-file f``).
    env : dict, optional
        Extra environment on top of ``os.environ``.
    """

    def __init__(self, module: str, ros_args: Sequence[str] = (), *,
                 env: dict[str, str] | None = None) -> None:
        child_env = {**os.environ, 'PYTHONUNBUFFERED': '1',
                     'RCUTILS_LOGGING_BUFFERED_STREAM': '0', **(env or {})}
        child_env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
        self._out = tempfile.TemporaryFile()
        self._err = tempfile.TemporaryFile()
        self.process = subprocess.Popen(
            [sys.executable, '-m', module, '--ros-args', *ros_args],
            stdin=subprocess.DEVNULL, stdout=self._out, stderr=self._err, env=child_env)

    def __enter__(self) -> NodeProcess:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.kill()

    @property
    def pid(self) -> int:
        return self.process.pid

    def exited(self) -> bool:
        """Whether the child has exited (use in ``Listener.spin_until``)."""
        return self.process.poll() is not None

    def stderr_so_far(self) -> str:
        """What the child has written to stderr until now (rclpy logs go there)."""
        self._err.flush()
        return _read(self._err)

    def wait_for_stderr(self, text: str, timeout: float) -> None:
        """Wait until ``text`` appears on the child's stderr; fail if it exits or times out."""
        deadline = time.monotonic() + timeout
        while text not in self.stderr_so_far():
            if self.process.poll() is not None:
                raise AssertionError(f'node exited ({self.process.returncode}) before '
                                     f'printing {text!r}: {self.stderr_so_far()}')
            if time.monotonic() > deadline:
                raise AssertionError(f'no {text!r} on stderr after {timeout} s: '
                                     f'{self.stderr_so_far()}')
            time.sleep(0.05)

    def wait(self, timeout: float) -> NodeOutput:
        """Wait for the child to exit by itself; kill it and fail after ``timeout`` s."""
        try:
            self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(f'node still running after {timeout} s; killed. stderr: '
                                 f'{self.stderr_so_far()}') from None
        return NodeOutput(self.process.returncode, _read(self._out), _read(self._err))

    def stop(self, sig: int = signal.SIGINT, timeout: float = STOP_TIMEOUT) -> NodeOutput:
        """Send ``sig`` and wait for the exit (killed, and the test fails, after ``timeout``)."""
        if self.process.poll() is None:
            self.process.send_signal(sig)
        return self.wait(timeout)

    def kill(self) -> None:
        """SIGKILL the child if it still runs, and reap it."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


def _read(file: Any) -> str:
    file.seek(0)
    return file.read().decode(errors='replace')


class Listener:
    """Subscriptions in a fresh rclpy Context, with their own node and EventsExecutor.

    Messages are appended to lists as they arrive while :meth:`spin_until` runs.
    Call :meth:`close` (in a fixture's teardown) to shut the context down.
    """

    def __init__(self, name: str = 'test_listener') -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)

    def subscribe(self, msg_type: Any, topic: str, qos: QoSProfile | None = None) -> list[Any]:
        """Subscribe to ``topic``; return the list the messages will be appended to."""
        received: list[Any] = []
        self.node.create_subscription(msg_type, topic, received.append,
                                      reliable() if qos is None else qos)
        return received

    def spin_until(self, done: Callable[[], bool], timeout: float) -> bool:
        """Spin until ``done()`` is true (returns True) or ``timeout`` s pass (False)."""
        deadline = time.monotonic() + timeout
        while not done():
            if time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=0.01)
        return True

    def call(self, srv_type: Any, name: str, request: Any,
             timeout: float = SERVICE_TIMEOUT) -> Any:
        """Call service ``name`` over DDS; return the response (fail after ``timeout`` s)."""
        client = self.node.create_client(srv_type, name)
        try:
            assert self.spin_until(client.service_is_ready, timeout), f'no service {name}'
            future = client.call_async(request)
            assert self.spin_until(future.done, timeout), f'{name}: no answer in {timeout} s'
            return future.result()
        finally:
            self.node.destroy_client(client)

    def set_parameters(self, node: str, **values: Any) -> list[SetParametersResult]:
        """Set parameters of ``node`` (its name) through its ``set_parameters`` service."""
        request = SetParameters.Request(parameters=[
            Parameter(name, value=value).to_parameter_msg() for name, value in values.items()])
        return list(self.call(SetParameters, f'{node}/set_parameters', request).results)

    def describe_parameters(self, node: str, *names: str) -> list[ParameterDescriptor]:
        """The descriptors of parameters ``names`` of ``node`` (its name)."""
        request = DescribeParameters.Request(names=list(names))
        return list(self.call(DescribeParameters, f'{node}/describe_parameters',
                              request).descriptors)

    def close(self) -> None:
        """Destroy the node and shut the context down."""
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()
