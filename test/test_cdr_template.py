"""CdrTemplate: patched serialized messages deserialize to the messages they stand for."""

from __future__ import annotations

import array
import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from safe_legged_c3bf.nodes.messages import time_parts
from safe_legged_c3bf.nodes.ros_common import to_time_msg
from safe_legged_c3bf.nodes.simulator.cdr_template import CdrTemplate
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray

STAMP = ["header.stamp.sec", "header.stamp.nanosec"]


def _set(msg, path: str, value) -> None:
    *parents, name = path.split(".")
    for p in parents:
        p, _, index = p.partition("[")
        msg = getattr(msg, p)
        if index:
            msg = msg[int(index[:-1])]
    if name.endswith("]"):
        name, _, index = name.partition("[")
        getattr(msg, name)[int(index[:-1])] = value
    else:
        setattr(msg, name, value)


def _check(prototype, groups, rng, rounds: int = 20) -> None:
    template = CdrTemplate(prototype, groups)
    msg = prototype
    for _ in range(rounds):
        for group, paths in groups.items():
            if group == "stamp" or paths[0].endswith("sec"):
                values = [int(rng.integers(0, 2**31 - 1)), int(rng.integers(0, 10**9))]
            else:
                values = [float(v) for v in rng.normal(size=len(paths))]
            template.set(group, *values)
            for path, value in zip(paths, values, strict=True):
                _set(msg, path, value)
        assert deserialize_message(template.bytes(), type(prototype)) == msg


def test_state_messages_round_trip():
    rng = np.random.default_rng(4)
    odom = Odometry()
    odom.header.frame_id, odom.child_frame_id = "odom", "base_link"
    odom.pose.covariance[0] = 0.25  # untouched fields keep the prototype's values
    _check(odom, {
        "stamp": STAMP,
        "pose": [f"pose.pose.position.{a}" for a in "xyz"]
        + [f"pose.pose.orientation.{a}" for a in "xyzw"],
        "twist": [f"twist.twist.linear.{a}" for a in "xyz"]
        + [f"twist.twist.angular.{a}" for a in "xyz"],
    }, rng)
    imu = Imu()
    imu.header.frame_id = "base_link"
    _check(imu, {
        "stamp": STAMP,
        "orientation": [f"orientation.{a}" for a in "xyzw"],
        "angular_velocity": [f"angular_velocity.{a}" for a in "xyz"],
        "linear_acceleration": [f"linear_acceleration.{a}" for a in "xyz"],
    }, rng)
    joints = JointState()
    joints.name = ["FR_hip_joint", "FR_upper_joint", "FR_lower_joint", "x"]
    for field in ("position", "velocity", "effort"):
        setattr(joints, field, array.array("d", [0.0] * 4))
    _check(joints, {"stamp": STAMP} | {
        field: [f"{field}[{i}]" for i in range(4)] for field in ("position", "velocity", "effort")
    }, rng)
    _check(Clock(), {"stamp": ["clock.sec", "clock.nanosec"]}, rng)
    obstacles = ObstacleArray()
    obstacles.header.frame_id = "odom"
    obstacles.obstacles = [Obstacle(id=name, semi_axis_a=0.3) for name in ("a", "bb", "ccc")]
    _check(obstacles, {"stamp": STAMP} | {
        f"o{i}": [f"obstacles[{i}].center.{a}" for a in "xyz"]
        + [f"obstacles[{i}].velocity.{a}" for a in "xyz"]
        for i in (0, 2)
    }, rng)


def test_rejects_fields_it_cannot_patch():
    with pytest.raises(ValueError, match="cannot be patched"):
        CdrTemplate(Odometry(), {"frame": ["header.frame_id"]})
    with pytest.raises(ValueError, match="not adjacent"):  # the covariance lies in between
        CdrTemplate(Odometry(), {"pose_twist": ["pose.pose.orientation.w",
                                                "twist.twist.linear.x"]})


def test_time_parts_match_to_time_msg():
    for t in (0.0, 0.001, 0.999, 1.0, 2.5, 1234.567, 2999.999, 0.004 * 12345, math.pi):
        msg = to_time_msg(t)
        assert time_parts(t) == (msg.sec, msg.nanosec)
