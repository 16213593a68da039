"""Message conversions, written once: time stamps, odometry, twists, obstacles, range data.

Every node and tool converts between ROS messages and the package's plain types here.
Frames: odometry pose in odom, twist in base_link (REP-105); obstacles in odom; scans and
clouds in their sensor's frame. Units SI.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan, PointCloud2

from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf_msgs.msg import Obstacle

if TYPE_CHECKING:
    from safe_legged_c3bf.perception.sensor_points import ScanPoints


def time_parts(seconds: float) -> tuple[int, int]:
    """(sec, nanosec) of builtin_interfaces/Time for ``seconds``."""
    sec = math.floor(seconds)
    return int(sec), int(round((seconds - sec) * 1e9)) % 1_000_000_000


def to_time_msg(seconds: float) -> TimeMsg:
    """builtin_interfaces/Time from seconds."""
    sec, nanosec = time_parts(seconds)
    return TimeMsg(sec=sec, nanosec=nanosec)


def from_time_msg(stamp: TimeMsg) -> float:
    """Seconds from builtin_interfaces/Time."""
    return stamp.sec + stamp.nanosec * 1e-9


def odometry_to_base_state(msg: Odometry) -> BaseState:
    """BaseState from nav_msgs/Odometry (pose in odom, twist in base_link)."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    return BaseState(
        position=(p.x, p.y, p.z),
        orientation=(q.x, q.y, q.z, q.w),
        linear_velocity=(v.x, v.y, v.z),
        angular_velocity=(w.x, w.y, w.z),
        stamp=from_time_msg(msg.header.stamp),
    )


def twist_to_command(msg: Twist) -> VelocityCommand:
    """VelocityCommand from a base_link Twist (linear.z = vertical body speed)."""
    return VelocityCommand(msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.z)


def command_to_twist(cmd: VelocityCommand, out: Twist | None = None) -> Twist:
    """Twist (base_link) from a VelocityCommand; ``out``: a Twist to fill instead of a new one.

    Reusing one Twist for a publisher is safe: ``publish`` serialises it before returning.
    """
    msg = Twist() if out is None else out
    msg.linear.x, msg.linear.y, msg.linear.z = float(cmd.vx), float(cmd.vy), float(cmd.vz)
    msg.angular.z = float(cmd.yaw_rate)
    return msg


def twist_is_finite(msg: Twist) -> bool:
    """True when every component of the Twist is finite."""
    values = (msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.x, msg.angular.y, msg.angular.z)
    return all(math.isfinite(v) for v in values)


def odometry_is_finite(msg: Odometry) -> bool:
    """True when pose, twist and quaternion norm are finite and the quaternion is non-zero."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w]
    t = msg.twist.twist
    values += [t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z]
    if not all(map(math.isfinite, values)):
        return False
    return q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w > 1e-12  # norm > 1e-6


def obstacle_to_msg(
    obs: Any, msg: Obstacle | None = None, velocity_source: int | None = None,
    send_velocity: bool = True,
) -> Obstacle:
    """safe_legged_c3bf_msgs/Obstacle of an obstacle-like object (filled into ``msg``).

    ``obs`` has ``id``, ``plane`` (0 vertical, 1 horizontal), ``center`` and ``velocity``
    (odom, m and m/s), ``semi_axes``, ``orientation``, ``extent`` and 3x3
    ``position_covariance`` / ``velocity_covariance``; ``velocity_source`` defaults to
    ``obs.velocity_source``. With ``send_velocity`` False the velocity stays zero (unknown).
    """
    if msg is None:
        msg = Obstacle()
    msg.id = obs.id
    msg.plane = int(obs.plane)
    center, velocity = msg.center, msg.velocity
    center.x, center.y, center.z = (float(c) for c in obs.center)
    if send_velocity:
        velocity.x, velocity.y, velocity.z = (float(v) for v in obs.velocity)
    msg.semi_axis_a, msg.semi_axis_b = float(obs.semi_axes[0]), float(obs.semi_axes[1])
    msg.orientation = float(obs.orientation)
    msg.extent = float(obs.extent)
    msg.position_covariance = np.asarray(obs.position_covariance, float).reshape(9)
    msg.velocity_covariance = np.asarray(obs.velocity_covariance, float).reshape(9)
    msg.velocity_source = int(obs.velocity_source if velocity_source is None else velocity_source)
    return msg


def laser_scan_points(msg: LaserScan) -> ScanPoints:
    """The valid returns of a LaserScan in its frame (REP-117 readings dropped).

    Raises SensorInputError ('malformed') for unusable scan geometry.
    """
    # Imported here: the perception package pulls scipy, which most nodes never need.
    from safe_legged_c3bf.perception.sensor_points import scan_points

    return scan_points(
        np.asarray(msg.ranges, dtype=float), msg.angle_min, msg.angle_increment,
        msg.range_min, msg.range_max, msg.time_increment,
    )


def point_cloud_xyz(msg: PointCloud2) -> np.ndarray:
    """(n, 3) finite x, y, z of a PointCloud2 in its frame (m).

    Raises SensorInputError ('malformed') when the fields or the data layout are unusable.
    """
    from safe_legged_c3bf.perception.sensor_points import CloudField, cloud_points

    fields = [CloudField(f.name, f.offset, f.datatype, f.count) for f in msg.fields]
    return cloud_points(
        msg.data, fields, msg.point_step, msg.row_step, msg.width, msg.height,
        bool(msg.is_bigendian),
    )
