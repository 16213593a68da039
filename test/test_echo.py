"""The echo tool: ros2-topic-echo YAML layout, type discovery, clear error for a missing topic."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

from conftest import spin_until
from geometry_msgs.msg import Twist
from message_samples import samples
from sensor_msgs.msg import JointState

from safe_legged_c3bf.echo import message_to_yaml
from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.ros_common import qos

TWIST_YAML = """linear:
  x: 0.5
  y: 0.0
  z: -0.1
angular:
  x: 0.0
  y: 0.0
  z: 0.25
"""


def _twist() -> Twist:
    msg = Twist()
    msg.linear.x, msg.linear.z, msg.angular.z = 0.5, -0.1, 0.25
    return msg


def test_twist_layout_matches_ros2_topic_echo():
    assert message_to_yaml(_twist()) == TWIST_YAML


def test_arrays_strings_and_nested_messages():
    js = JointState()
    js.header.frame_id = ""
    js.name = ["a", "b"]
    js.position = [1.0, 2.5e-07]
    text = message_to_yaml(js)
    assert "header:\n  stamp:\n    sec: 0\n    nanosec: 0\n  frame_id: ''\n" in text
    assert "name:\n- a\n- b\n" in text
    assert "position:\n- 1.0\n- 2.5e-07\n" in text
    assert "velocity: []\n" in text

    state = samples()["SafetyFilterState"]
    state.min_h = float("inf")
    text = message_to_yaml(state)
    assert "status: 3\n" in text and "reference_stale: true\n" in text
    assert "constraint_active:\n- true\n- false\n" in text
    assert "min_h: .inf\n" in text

    arr = samples()["ObstacleArray"]
    text = message_to_yaml(arr)
    assert "obstacles:\n- id: pillar_0\n  plane: 1\n  center:\n    x: 3.0\n" in text
    assert "  position_covariance:\n  - 0.0\n  - 0.001\n" in text  # fixed-size array


def _echo(*args: str, timeout: float = 30) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.echo", *args],
        capture_output=True, text=True, timeout=timeout, env=dict(os.environ),
    )


def test_echo_prints_published_messages(ros_executor):
    import rclpy

    node = rclpy.create_node("echo_test_talker", context=ros_executor.context_for_nodes)
    ros_executor.add_node(node)
    pub = node.create_publisher(Twist, topics.CMD_VEL_SAFE.name, qos(topics.CMD_VEL_SAFE))
    stop = threading.Event()

    def publish() -> None:
        while not stop.is_set():
            pub.publish(_twist())
            time.sleep(0.02)

    spin_until(ros_executor, lambda: False, timeout=0.2)
    thread = threading.Thread(target=publish, daemon=True)
    thread.start()
    try:
        out = _echo(topics.CMD_VEL_SAFE.name, "-n", "2")
    finally:
        stop.set()
        thread.join()
    assert out.returncode == 0, out.stderr
    assert out.stdout == (TWIST_YAML + "---\n") * 2


def test_echo_missing_topic_is_a_clear_error():
    out = _echo("/no_such_topic", "--once", "--timeout", "1")
    assert out.returncode == 1
    assert "/no_such_topic did not appear within 1 s" in out.stderr
    assert "ROS domain" in out.stderr
