"""Helpers shared by the rclpy node wrappers.

QoS from the topic contract, time stamps, odometry and twist conversions, diagnostics, and a
standard ``main`` for a single node.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Iterable

import rclpy
from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from safe_legged_c3bf.base_state import BaseState
from safe_legged_c3bf.gait_controller import VelocityCommand
from safe_legged_c3bf.topics import Topic

DIAGNOSTIC_LEVELS = {
    "ok": DiagnosticStatus.OK,
    "warn": DiagnosticStatus.WARN,
    "error": DiagnosticStatus.ERROR,
    "stale": DiagnosticStatus.STALE,
}


def qos(topic: Topic) -> QoSProfile:
    """QoS profile of a contract topic."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=topic.depth,
        reliability=ReliabilityPolicy.RELIABLE if topic.reliable else ReliabilityPolicy.BEST_EFFORT,
    )


def publisher(node: Node, topic: Topic):  # noqa: ANN201 - rclpy Publisher
    """Publisher of a contract topic: its name, message type and QoS from ``topics.py``."""
    return node.create_publisher(topic.msg_class(), topic.name, qos(topic))


def subscription(node: Node, topic: Topic, callback: Callable, raw: bool = False):  # noqa: ANN201
    """Subscription to a contract topic: its name, message type and QoS from ``topics.py``.

    ``raw``: the callback receives the serialized bytes (to bound work before decoding).
    """
    return node.create_subscription(
        topic.msg_class(), topic.name, callback, qos(topic), raw=raw
    )


class SinglePublisher:
    """Whether a topic has at most one publisher, asked of the ROS graph every ``period`` s.

    rclpy gives a callback no publisher identity, so two publishers on one topic cannot be
    told apart message by message. Where believing the wrong one is unsafe (odometry and
    obstacles for the filter, the safe command for the gait controller) the receiver rejects
    the topic's messages while it has more than one publisher, and fails safe.
    """

    def __init__(self, node: Node, topic: Topic, period: float = 0.2) -> None:
        """Watch ``topic`` for ``node``; ``period``: wall seconds between graph queries."""
        self._node, self._name, self._period = node, topic.name, period
        self._asked = -math.inf
        self._count = 0

    @property
    def count(self) -> int:
        """Publishers on the topic (at most ``period`` s old)."""
        now = time.monotonic()
        if now - self._asked >= self._period:
            self._count = self._node.count_publishers(self._name)
            self._asked = now
        return self._count

    def ok(self) -> bool:
        """True while the topic has at most one publisher."""
        return self.count <= 1


def use_sim_time(node: Node, enabled: bool = True) -> None:
    """Switch ``node`` to sim time from /clock (a no-op if the parameter is already set)."""
    if node.has_parameter("use_sim_time"):
        node.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, enabled)])


def to_time_msg(seconds: float) -> TimeMsg:
    """builtin_interfaces/Time from seconds."""
    sec = math.floor(seconds)
    return TimeMsg(sec=int(sec), nanosec=int(round((seconds - sec) * 1e9)) % 1_000_000_000)


def from_time_msg(stamp: TimeMsg) -> float:
    """Seconds from builtin_interfaces/Time."""
    return stamp.sec + stamp.nanosec * 1e-9


def now_seconds(node: Node) -> float:
    """The node's clock (sim time when use_sim_time is set) in seconds."""
    return node.get_clock().now().nanoseconds * 1e-9


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


def diagnostic_status(
    name: str, level: str, message: str, values: dict[str, object] | None = None
) -> DiagnosticStatus:
    """A DiagnosticStatus; ``level`` is 'ok', 'warn', 'error' or 'stale'."""
    status = DiagnosticStatus(
        level=DIAGNOSTIC_LEVELS[level], name=name, message=message, hardware_id="sim"
    )
    status.values = [KeyValue(key=str(k), value=str(v)) for k, v in (values or {}).items()]
    return status


def diagnostic_array(node: Node, statuses: Iterable[DiagnosticStatus]) -> DiagnosticArray:
    """DiagnosticArray stamped with the node's clock."""
    msg = DiagnosticArray()
    msg.header.stamp = node.get_clock().now().to_msg()
    msg.status = list(statuses)
    return msg


def run_node(factory: Callable[[], Node], args: list[str] | None = None) -> int:
    """Standard ``main`` body: init, spin one node until Ctrl-C/SIGTERM, clean shutdown."""
    rclpy.init(args=sys.argv if args is None else args)
    node = None
    try:
        node = factory()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
