"""A node that poisons one input topic of a running graph and watches what follows.

:class:`FaultInjector` publishes a :class:`~safe_legged_c3bf.evaluation.faults.Fault`'s
messages (a second publisher on the topic) at the fault's rate of wall time once
:meth:`start` is called, and records, from the graph's own topics: the robot's measured speed
(the simulator's /odom; the injector's own /odom messages carry ``child_frame_id``
``FAULT_FRAME`` and are skipped), collisions (/ground_truth/safety) and every node's
``rejected_*`` counters (/diagnostics). Times: sim seconds (the node runs on sim time).
"""

from __future__ import annotations

import math
import time
from collections import deque

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from safe_legged_c3bf.evaluation.faults import Fault
from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf_msgs.msg import Obstacle

FAULT_FRAME = "fault_injector"
_OFFSETS = {"sim": 0.0, "future": 100.0, "past": -5.0}
_TOPICS = {t.name: t for t in topics.CONTRACT}


def _obstacle(x: float, y: float, nan: bool = False) -> Obstacle:
    o = Obstacle()
    o.id = ""
    o.center.x, o.center.y, o.center.z = (math.nan if nan else x), y, 0.5
    o.semi_axis_a = o.semi_axis_b = 0.2
    o.extent = 1.0
    return o


def _scan(msg, distance: float) -> None:  # noqa: ANN001 - sensor_msgs/LaserScan
    """A 360-beam scan with every range ``distance`` (m; NaN: no return, REP-117)."""
    msg.angle_min, msg.angle_increment = -math.pi, 2.0 * math.pi / 360
    msg.angle_max = msg.angle_min + 359 * msg.angle_increment
    msg.range_min, msg.range_max = 0.1, 10.0
    msg.ranges = [distance] * 360


def _cloud(msg, points: np.ndarray, truncate: bool = False) -> None:  # noqa: ANN001
    """An x, y, z float32 PointCloud2 of ``points`` (n, 3); ``truncate``: data cut short."""
    from safe_legged_c3bf.nodes.simulator.sensor_publisher import fill_cloud, xyz_fields

    msg.fields = xyz_fields()
    fill_cloud(msg, points)
    if truncate:
        msg.data = msg.data[: len(msg.data) // 3]


def _fill(payload: str, msg) -> None:  # noqa: ANN001 - any contract message
    """Fill ``msg`` (a fresh message of the fault's topic) with ``payload``."""
    if payload == "scan_phantom":  # a ring of returns 0.6 m around the sensor
        _scan(msg, 0.6)
    elif payload == "scan_no_returns":
        _scan(msg, math.nan)
    elif payload in ("points_phantom", "points_truncated"):  # a wall 0.8 m ahead
        y, z = np.meshgrid(np.linspace(-1.0, 1.0, 40), np.linspace(-0.2, 0.5, 15))
        wall = np.column_stack([np.full(y.size, 0.8), y.ravel(), z.ravel()])
        _cloud(msg, wall, truncate=payload == "points_truncated")
    elif payload == "nan_obstacle":
        msg.obstacles = [_obstacle(3.0, 0.0, nan=True)]
    elif payload == "far_obstacle":
        msg.obstacles = [_obstacle(12.0, 8.0)]
    elif payload == "many_obstacles":
        msg.obstacles = [_obstacle(-5.0 - 0.01 * k, 10.0 + 0.01 * k) for k in range(10000)]
    elif payload in ("odom_elsewhere", "odom_nan"):
        msg.child_frame_id = FAULT_FRAME
        msg.pose.pose.position.x = math.nan if payload == "odom_nan" else -20.0
        msg.pose.pose.orientation.w = 1.0
    elif payload == "twist_nan":
        msg.linear.x = math.nan
    elif payload == "twist_full_speed":
        msg.linear.x = 0.8
    elif payload == "imu_level":
        msg.orientation.w = 1.0
    elif payload == "joints_zero":
        msg.name = ["not_a_joint"]
        msg.position = [0.0]


class FaultInjector(Node):
    """Publishes one message fault on demand and records the graph's response."""

    def __init__(self, faults: list[Fault], **kwargs) -> None:
        """Prepare publishers for the message ``faults`` (process faults are ignored here)."""
        super().__init__("fault_injector", **kwargs)
        ros_common.use_sim_time(self)
        self.faults = [f for f in faults if not f.is_process]
        self.sim_time: float | None = None
        self.start_time: float | None = None
        self.sent = 0
        self.speeds: deque[tuple[float, float]] = deque(maxlen=100000)  # (t, m/s)
        self.collided = False
        self.rejected: dict[tuple[str, str], int] = {}  # (node, key) -> latest counter
        self.rejected_at_start: dict[tuple[str, str], int] = {}
        self._timers = []
        ros_common.subscription(self, topics.ODOM, self._on_odom)
        ros_common.subscription(self, topics.GROUND_TRUTH_SAFETY, self._on_safety)
        ros_common.subscription(self, topics.DIAGNOSTICS, self._on_diagnostics)
        ros_common.subscription(self, topics.CLOCK, self._on_clock)

    # -- recording ----------------------------------------------------------------------------
    def _on_clock(self, msg) -> None:  # noqa: ANN001 - rosgraph_msgs/Clock
        self.sim_time = ros_common.from_time_msg(msg.clock)

    def _on_odom(self, msg) -> None:  # noqa: ANN001 - nav_msgs/Odometry
        if msg.child_frame_id == FAULT_FRAME:
            return
        v = msg.twist.twist.linear
        self.speeds.append((ros_common.from_time_msg(msg.header.stamp), math.hypot(v.x, v.y)))

    def _on_safety(self, msg) -> None:  # noqa: ANN001 - GroundTruthSafety
        self.collided = self.collided or bool(msg.in_collision)

    def _on_diagnostics(self, msg) -> None:  # noqa: ANN001 - DiagnosticArray
        for status in msg.status:
            for kv in status.values:
                if kv.key.startswith("rejected_") and kv.key not in (
                    "rejected_total", "rejected_messages"
                ):
                    try:
                        self.rejected[(status.name, kv.key)] = int(kv.value)
                    except ValueError:
                        pass

    @property
    def rejected_since_start(self) -> int:
        """Messages the graph rejected (every node's ``rejected_*``) since :meth:`start`."""
        return sum(
            max(n - self.rejected_at_start.get(key, 0), 0) for key, n in self.rejected.items()
        )

    def time_to_stop(self, window: float = 0.5, speed: float = 0.08) -> float | None:
        """Sim s from :meth:`start` until the robot stands for the rest of the record.

        Standing: the mean measured speed over the next ``window`` s is below ``speed`` m/s.
        None if the robot never stands.
        """
        if self.start_time is None:
            return None
        data = np.array([(t, v) for t, v in self.speeds if t >= self.start_time])
        if len(data) == 0:
            return None
        t, v = data[:, 0], data[:, 1]
        sums = np.concatenate([[0.0], np.cumsum(v)])
        end = np.searchsorted(t, t + window, side="right")
        mean = (sums[end] - sums[:-1]) / (end - np.arange(len(t)))
        moving = np.nonzero(mean >= speed)[0]
        first = 0 if len(moving) == 0 else moving[-1] + 1
        return None if first >= len(t) else float(t[first] - self.start_time)

    # -- injecting ----------------------------------------------------------------------------
    def start(self) -> None:
        """Start publishing every message fault at its rate (wall clock).

        The publishers are created only now: a second publisher on a topic is itself part
        of some faults, and must not exist before the fault time.
        """
        self.start_time = self.sim_time
        self.rejected_at_start = dict(self.rejected)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        for fault in self.faults:
            topic = _TOPICS[fault.topic]
            msg = topic.msg_class()()
            _fill(fault.payload, msg)
            pub = ros_common.publisher(self, topic)
            self._timers.append(self.create_timer(
                1.0 / fault.rate, lambda f=fault, p=pub, m=msg: self._send(f, p, m), clock=steady
            ))

    def _stamp(self, fault: Fault) -> TimeMsg:
        if fault.stamp == "wall":
            return ros_common.to_time_msg(time.time())
        t = (self.sim_time or 0.0) + _OFFSETS[fault.stamp]
        return ros_common.to_time_msg(max(t, 1e-3))

    def _send(self, fault: Fault, pub, msg) -> None:  # noqa: ANN001
        if hasattr(msg, "header"):
            msg.header.stamp = self._stamp(fault)
            msg.header.frame_id = fault.frame
        pub.publish(msg)
        self.sent += 1
