"""The bringup's own node: watches a run and keeps the time series for its report.

Subscribes to /odom, /cmd_vel, /cmd_vel_safe, /c3bf/state, /ground_truth/safety,
/ground_truth/obstacles and /diagnostics (names and QoS from the topic contract). Sim time is
taken from the newest message stamp (the monitor does not listen to the 1 kHz /clock), so it
costs little CPU. Messages without a stamp (Twist) are filed under the newest sim time seen.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.rotations import yaw_from_quaternion
from safe_legged_c3bf.nodes.ros_common import from_time_msg
from safe_legged_c3bf.run.recorder import qos

#: SafetyFilterState status codes -> names (the .msg constants).
STATUS_NAMES = {
    0: "PASS_THROUGH", 1: "INACTIVE", 2: "ACTIVE", 3: "RELAXED", 4: "EMERGENCY_BRAKE",
    5: "STALE_INPUT", 6: "INVALID_INPUT",
}
#: Statuses in which the filter changed the reference command.
INTERVENING = frozenset({2, 3, 4})
#: Diagnostic levels -> names.
LEVEL_NAMES = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}
#: Obstacle positions are kept at most this often (s, sim time) for the top-view paths.
OBSTACLE_SAMPLE_PERIOD = 0.1
#: Reader-side queue depth: the monitor shares a core with the nodes and may fall behind.
QUEUE_DEPTH = 100
#: Diagnostic status changes kept for the report.
MAX_EVENTS = 2000


@dataclass
class ObstacleTrack:
    """Ground-truth trajectory and shape of one obstacle."""

    id: str
    plane: int
    semi_axes: tuple[float, float]
    orientation: float
    extent: float
    t: list[float] = field(default_factory=list)
    xyz: list[tuple[float, float, float]] = field(default_factory=list)


@dataclass
class RunData:
    """Everything the monitor collected (lists of rows; see :meth:`arrays`)."""

    odom: list[tuple[float, ...]] = field(default_factory=list)  # t x y z yaw vx vy vz wz
    cmd_vel: list[tuple[float, ...]] = field(default_factory=list)  # t vx vy vz wz
    cmd_vel_safe: list[tuple[float, ...]] = field(default_factory=list)  # t vx vy vz wz
    # t status min_h solve_time ref(vx vy vz wz) filtered(vx vy vz wz)
    filter_state: list[tuple[float, ...]] = field(default_factory=list)
    barrier: dict[str, list[tuple[float, float]]] = field(default_factory=dict)  # id -> (t, h)
    # t in_collision collision_count min_distance fallen
    safety: list[tuple[float, ...]] = field(default_factory=list)
    closest: list[str] = field(default_factory=list)  # closest obstacle id per safety row
    contacts: set[str] = field(default_factory=set)
    obstacles: dict[str, ObstacleTrack] = field(default_factory=dict)
    diagnostics: dict[str, tuple[str, str]] = field(default_factory=dict)  # name -> (lvl, msg)
    diagnostic_events: list[tuple[float, str, str, str]] = field(default_factory=list)
    solver_names: set[str] = field(default_factory=set)
    wall_start: float | None = None  # wall time of the first stamped message
    sim_start: float | None = None  # its sim time
    wall_last: float | None = None
    sim_last: float | None = None

    def arrays(self) -> dict[str, np.ndarray]:
        """The tabular series as numpy arrays (empty arrays with the right width if none)."""
        widths = {"odom": 9, "cmd_vel": 5, "cmd_vel_safe": 5, "filter_state": 12, "safety": 5}
        out = {}
        for name, width in widths.items():
            rows = getattr(self, name)
            out[name] = np.array(rows, dtype=float).reshape(-1, width)
        return out


class MonitorNode(Node):
    """Collects :class:`RunData` and the live values of the progress line."""

    def __init__(self, node_name: str = "bringup_monitor", **kwargs) -> None:
        """Create the subscriptions; ``kwargs`` go to rclpy's Node."""
        super().__init__(node_name, **kwargs)
        self.data = RunData()
        self.status_text = "-"
        self.goal: tuple[float, float] | None = None
        self.goal_tolerance = 0.3
        #: Sim times (s) of the first goal arrival, collision and fall; None until seen.
        self.goal_time: float | None = None
        self.collision_time: float | None = None
        self.fall_time: float | None = None
        self._rtf_window: deque[tuple[float, float]] = deque()
        subs = [
            (topics.ODOM, self._on_odom),
            (topics.CMD_VEL, self._twist_handler(self.data.cmd_vel)),
            (topics.CMD_VEL_SAFE, self._twist_handler(self.data.cmd_vel_safe)),
            (topics.FILTER_STATE, self._on_filter_state),
            (topics.GROUND_TRUTH_SAFETY, self._on_safety),
            (topics.GROUND_TRUTH_OBSTACLES, self._on_obstacles),
            (topics.DIAGNOSTICS, self._on_diagnostics),
        ]
        for topic, callback in subs:
            self.create_subscription(
                topic.msg_class(), topic.name, callback, qos(topic, depth=QUEUE_DEPTH)
            )

    # -- time ---------------------------------------------------------------------------------
    @property
    def sim_time(self) -> float | None:
        """Newest sim time seen (s), None before the first stamped message."""
        return self.data.sim_last

    def _stamp(self, stamp) -> float:  # noqa: ANN001 - builtin_interfaces/Time
        t = from_time_msg(stamp)
        now = time.monotonic()
        d = self.data
        if d.sim_start is None or t <= d.sim_start:
            # Until sim time advances (the simulator holds t = 0 until the first command) the
            # start moves along, so the real-time factor counts from when physics runs.
            d.sim_start, d.wall_start = t, now
        if d.sim_last is None or t > d.sim_last:
            d.sim_last, d.wall_last = t, now
            if self._rtf_window and now - self._rtf_window[-1][0] > 1.0:
                self._rtf_window.clear()  # sim time stood still: measure afresh
            self._rtf_window.append((now, t))
            while len(self._rtf_window) > 2 and now - self._rtf_window[0][0] > 3.0:
                self._rtf_window.popleft()
        return t

    def real_time_factor(self) -> float | None:
        """Sim seconds per wall second over the last few seconds (None until known)."""
        if len(self._rtf_window) < 2:
            return None
        (w0, s0), (w1, s1) = self._rtf_window[0], self._rtf_window[-1]
        if time.monotonic() - w1 > 1.0:  # sim stopped publishing: measure up to now
            w1 = time.monotonic()
        return (s1 - s0) / (w1 - w0) if w1 > w0 else None

    def overall_real_time_factor(self) -> float | None:
        """Sim seconds per wall second since the first message."""
        d = self.data
        if d.wall_start is None or d.wall_last is None or d.wall_last <= d.wall_start:
            return None
        return (d.sim_last - d.sim_start) / (d.wall_last - d.wall_start)

    # -- live values --------------------------------------------------------------------------
    def position(self) -> tuple[float, float] | None:
        """Latest base position (x, y) in odom."""
        if not self.data.odom:
            return None
        row = self.data.odom[-1]
        return row[1], row[2]

    def distance_to_goal(self) -> float | None:
        """Distance from the base to the goal (m), None if unknown."""
        pos = self.position()
        if pos is None or self.goal is None:
            return None
        return math.dist(pos, self.goal)

    def decided(self, hold: float) -> str | None:
        """Why the run's outcome is settled ``hold`` s (sim) after its first decisive event.

        Decisive: a collision, a fall, or the base within ``goal_tolerance`` of the goal.
        Returns None while nothing is settled.
        """
        t = self.sim_time
        if t is None:
            return None
        for label, when in (("collision", self.collision_time), ("fall", self.fall_time),
                            ("goal reached", self.goal_time)):
            if when is not None and t >= when + hold:
                return f"{label} at t = {when:.2f} s: run ended early (--full-duration runs on)"
        return None

    # -- callbacks ----------------------------------------------------------------------------
    def _on_odom(self, msg) -> None:  # noqa: ANN001
        t = self._stamp(msg.header.stamp)
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        v, w = msg.twist.twist.linear, msg.twist.twist.angular
        yaw = yaw_from_quaternion(q.x, q.y, q.z, q.w)
        self.data.odom.append((t, p.x, p.y, p.z, yaw, v.x, v.y, v.z, w.z))
        if (self.goal_time is None and self.goal is not None
                and math.dist((p.x, p.y), self.goal) <= self.goal_tolerance):
            self.goal_time = t

    def _twist_handler(self, rows: list):
        def on_twist(msg) -> None:  # noqa: ANN001
            t = self.data.sim_last
            if t is not None:
                rows.append((t, msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.z))

        return on_twist

    def _on_filter_state(self, msg) -> None:  # noqa: ANN001
        t = self._stamp(msg.header.stamp)
        r, f = msg.reference, msg.filtered
        self.data.filter_state.append((
            t, float(msg.status), float(msg.min_h), float(msg.solve_time),
            r.linear.x, r.linear.y, r.linear.z, r.angular.z,
            f.linear.x, f.linear.y, f.linear.z, f.angular.z,
        ))
        for obstacle_id, h in zip(msg.obstacle_ids, msg.h, strict=False):
            self.data.barrier.setdefault(obstacle_id, []).append((t, float(h)))
        if msg.solver:
            self.data.solver_names.add(msg.solver)
        self.status_text = msg.status_text or STATUS_NAMES.get(msg.status, str(msg.status))

    def _on_safety(self, msg) -> None:  # noqa: ANN001
        t = self._stamp(msg.header.stamp)
        self.data.safety.append((
            t, float(msg.in_collision), float(msg.collision_count), float(msg.min_distance),
            float(msg.fallen),
        ))
        self.data.closest.append(msg.closest_obstacle_id)
        if self.collision_time is None and (msg.in_collision or msg.collision_count > 0):
            self.collision_time = t
        if self.fall_time is None and msg.fallen:
            self.fall_time = t
        self.data.contacts.update(msg.contact_obstacle_ids)

    def _on_obstacles(self, msg) -> None:  # noqa: ANN001
        t = self._stamp(msg.header.stamp)
        for o in msg.obstacles:
            track = self.data.obstacles.get(o.id)
            if track is None:
                track = ObstacleTrack(
                    o.id, int(o.plane), (o.semi_axis_a, o.semi_axis_b), o.orientation, o.extent
                )
                self.data.obstacles[o.id] = track
            if track.t and t - track.t[-1] < OBSTACLE_SAMPLE_PERIOD:
                continue
            track.t.append(t)
            track.xyz.append((o.center.x, o.center.y, o.center.z))

    def _on_diagnostics(self, msg) -> None:  # noqa: ANN001
        t = self.data.sim_last if self.data.sim_last is not None else 0.0
        for status in msg.status:
            raw = status.level
            code = int.from_bytes(raw, "little") if isinstance(raw, bytes) else int(raw)
            level = LEVEL_NAMES.get(code, str(code))
            previous = self.data.diagnostics.get(status.name)
            if previous != (level, status.message):
                self.data.diagnostics[status.name] = (level, status.message)
                events = self.data.diagnostic_events
                if (level != "OK" or previous is not None) and len(events) < MAX_EVENTS:
                    events.append((t, status.name, level, status.message))
