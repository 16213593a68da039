"""Shared fixtures: every pytest session runs on a private ROS domain on localhost.

``ros_executor`` gives a test an in-process SingleThreadedExecutor; ``spin_until`` waits on a
condition (e.g. discovery) instead of sleeping.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable

import pytest

from safe_legged_c3bf.run.ros_domain import isolate_environment

# Must happen before rclpy creates any context.
_ENV, _DOMAIN_LEASE = isolate_environment()


def pytest_report_header(config):
    return " ".join(f"{key}={_ENV[key]}" for key in (
        "ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "FASTRTPS_DEFAULT_PROFILES_FILE")
        if key in _ENV)


@pytest.fixture(scope="session")
def ros_domain_id() -> int:
    """The ROS domain id of this test session."""
    return _DOMAIN_LEASE.domain_id


@pytest.fixture
def ros_executor():
    """An initialised rclpy context and a SingleThreadedExecutor; nodes added are destroyed."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.context_for_nodes = context  # convenience for tests creating nodes
    try:
        yield executor
    finally:
        for node in list(executor.get_nodes()):
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)


def spin_until(
    executor, predicate: Callable[[], bool], timeout: float = 10.0, step: float = 0.01
) -> bool:
    """Spin ``executor`` until ``predicate()`` is true or ``timeout`` (wall s) passes."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        executor.spin_once(timeout_sec=step)
    return predicate()


def wait_for_discovery(executor, publisher, subscriptions: int = 1, timeout: float = 10.0) -> bool:
    """Spin until ``publisher`` has matched at least ``subscriptions`` subscribers."""
    return spin_until(
        executor, lambda: publisher.get_subscription_count() >= subscriptions, timeout
    )


_NODE_PROBE = """
import gc, os, signal, sys
from rclpy.node import Node
from safe_legged_c3bf.nodes import ros_common

class Probe(Node):
    def __init__(self):
        super().__init__("node_probe")
        self.create_timer(0.05, self._tick)

    def _tick(self):
        print({report}, flush=True)
        os.kill(os.getpid(), signal.SIGINT)

sys.exit(ros_common.run_node(Probe, [sys.argv[0]]))
"""


def run_node_probe(report: str, env: dict[str, str]) -> subprocess.CompletedProcess:
    """Run a node process (``ros_common.run_node``) that prints ``report`` (a Python expression
    over ``self`` and ``gc``) on its first timer tick, then SIGINTs itself; wait for its exit."""
    return subprocess.run([sys.executable, "-c", _NODE_PROBE.replace("{report}", report)],
                          env=env, capture_output=True, text=True, timeout=60)
