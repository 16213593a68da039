"""Every custom message crosses processes over DDS and between in-process nodes unchanged."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from conftest import spin_until, wait_for_discovery
from message_samples import samples
from rclpy.qos import QoSProfile

NAMES = list(samples())

PUBLISHER_SCRIPT = textwrap.dedent(
    """
    import sys, time
    import rclpy
    from rclpy.qos import QoSProfile
    sys.path.insert(0, {test_dir!r})
    from message_samples import samples
    name = sys.argv[1]
    msg = samples()[name]
    rclpy.init()
    node = rclpy.create_node('sample_publisher')
    pub = node.create_publisher(type(msg), '/sample/' + name, QoSProfile(depth=10))
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        pub.publish(msg)
        rclpy.spin_once(node, timeout_sec=0.05)
    """
)


def _assert_equal(a, b):
    assert type(a) is type(b)
    assert a == b  # generated messages compare field by field


@pytest.mark.parametrize("name", NAMES)
def test_message_crosses_processes(ros_executor, name, tmp_path):
    msg = samples()[name]
    received = []
    import rclpy

    node = rclpy.create_node(f"rx_{name.lower()}", context=ros_executor.context_for_nodes)
    ros_executor.add_node(node)
    node.create_subscription(type(msg), "/sample/" + name, received.append, QoSProfile(depth=10))
    script = tmp_path / "pub.py"
    script.write_text(PUBLISHER_SCRIPT.format(test_dir=str(Path(__file__).parent)))
    proc = subprocess.Popen(
        [sys.executable, str(script), name], env=dict(os.environ), stderr=subprocess.PIPE
    )
    try:
        assert spin_until(ros_executor, lambda: bool(received), timeout=25.0), (
            f"no {name} received from the other process"
        )
    finally:
        proc.kill()
        proc.wait(timeout=10)
    _assert_equal(received[0], msg)


def test_messages_between_in_process_nodes(ros_executor):
    import rclpy

    ctx = ros_executor.context_for_nodes
    tx = rclpy.create_node("tx", context=ctx)
    rx = rclpy.create_node("rx", context=ctx)
    ros_executor.add_node(tx)
    ros_executor.add_node(rx)
    received: dict[str, list] = {n: [] for n in NAMES}
    pubs = {}
    for name, msg in samples().items():
        rx.create_subscription(
            type(msg), "/inproc/" + name, received[name].append, QoSProfile(depth=10)
        )
        pubs[name] = tx.create_publisher(type(msg), "/inproc/" + name, QoSProfile(depth=10))
    for pub in pubs.values():
        assert wait_for_discovery(ros_executor, pub)
    for name, msg in samples().items():
        pubs[name].publish(msg)
    assert spin_until(ros_executor, lambda: all(received.values()), timeout=10.0)
    for name, msg in samples().items():
        _assert_equal(received[name][0], msg)
