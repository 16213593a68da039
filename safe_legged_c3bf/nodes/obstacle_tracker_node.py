"""Obstacle tracker node: /obstacles/detections + /odom -> /obstacles, /obstacles/markers.

Every detection message (an ObstacleArray of noisy positions and shapes, no velocities) is
one batch for :class:`~safe_legged_c3bf.perception.MultiObstacleTracker`, stamped with the
message's header stamp; the robot position from /odom is the reference of the range check.
Detections the tracker rejects (NaN/Inf, non-positive or implausible size, wrong frame, out
of range, duplicate id, stale stamp) are counted by reason in /diagnostics, never published.

At ``rate`` Hz (sim time) the confirmed tracks are predicted to the current time and
published on /obstacles with their velocity and position/velocity covariances (stamp = the
time they were predicted to, frame = ``frame_id``). ``velocity_source`` is ESTIMATED once a
track's velocity is trustworthy; before that it is UNKNOWN and, as Obstacle.msg specifies,
the velocity is zero (``publish_unestimated_velocity`` sends the raw estimate instead).
When no detection message came for ``detections_timeout`` s (or none yet), nothing is
published, so that consumers see their obstacle input go stale instead of an empty world.

/obstacles/markers (at ``marker_rate`` Hz) draws each obstacle's ellipse as a cylinder
(upright, or lying along odom y for a horizontal bar), its inflated circle, a velocity arrow
(1 s of motion) and a label; every array starts with DELETEALL so vanished tracks disappear.

Changing a tracker parameter at run time restarts tracking with the new configuration (the
rejection counters are kept).

Untrusted inputs: a detection message is judged by its stamp against the node's own clock:
more than ``max_future_stamp`` ahead, or older than ``detections_timeout``, and the whole
batch is rejected (counted as ``future_stamp`` / ``stale_stamp``) and does not count as a
detection message for the freshness of /obstacles. So a publisher that is not on sim time
can neither make real detections look old nor keep /obstacles alive. Messages larger than
``max_message_bytes`` are rejected before decoding; batches of more than ``max_detections``
keep the nearest. Two detectors on one topic are merged (see ``TrackerConfig.max_reorder``).
/odom is judged the same way before its position and speed are used.

With ``scan_clearing`` the node also takes /scan (in ``lidar_frame``, placed in odom by the
LiDAR's mount and the /odom poses): a coasting track whose place the beams pass right through
is deleted (``perception/scan_clearing.py``), counted as ``tracks_cleared``. A scan is judged
like a detection message (size, frame, stamp; no pose for its stamp: ``scan_no_pose``).
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Point, Quaternion
from nav_msgs.msg import Odometry
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import LaserScan
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.rotations import matrix_to_quaternion
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.messages import obstacle_to_msg
from safe_legged_c3bf.nodes.parameters import NodeParameters
from safe_legged_c3bf.perception import (
    Detection,
    MultiObstacleTracker,
    ObstaclePlane,
    TrackedObstacle,
    TrackerConfig,
)
from safe_legged_c3bf.perception.params import ObstacleTrackerParams
from safe_legged_c3bf.perception.scan_clearing import ScanPlacer
from safe_legged_c3bf.safety import StampGate, StampVerdict
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray

#: Display length (m) of an obstacle with infinite extent.
INFINITE_EXTENT_DISPLAY = 2.0
MARKER_LIFETIME = 1.0  # s


def detections_from_msg(msg: ObstacleArray) -> list[Detection]:
    """Detections (unvalidated: the tracker checks them) from a detection message."""
    return [
        Detection(
            center=(o.center.x, o.center.y, o.center.z),
            semi_axes=(o.semi_axis_a, o.semi_axis_b),
            orientation=o.orientation,
            plane=int(o.plane),
            id=o.id,
            frame_id=msg.header.frame_id,
            extent=o.extent,
            position_covariance=np.asarray(o.position_covariance, dtype=float).reshape(3, 3),
        )
        for o in msg.obstacles
    ]


def ellipse_rotation(plane: ObstaclePlane | int, orientation: float) -> np.ndarray:
    """Rotation (odom <- marker) of a cylinder marker whose x axis is the ellipse's a axis.

    The marker's z axis (the cylinder axis) is odom z for a VERTICAL obstacle and odom y for
    a HORIZONTAL one, whose a axis is turned by ``orientation`` from +x towards +z.
    """
    c, s = math.cos(orientation), math.sin(orientation)
    if int(plane) == ObstaclePlane.HORIZONTAL:
        x_axis, z_axis = np.array([c, 0.0, s]), np.array([0.0, 1.0, 0.0])
    else:
        x_axis, z_axis = np.array([c, s, 0.0]), np.array([0.0, 0.0, 1.0])
    return np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis])


def _color(r: float, g: float, b: float, a: float) -> ColorRGBA:
    return ColorRGBA(r=r, g=g, b=b, a=a)


def obstacle_markers(
    obstacles: list[TrackedObstacle],
    stamp,  # noqa: ANN001 - builtin_interfaces/Time
    frame_id: str,
    inflation: float = 0.0,
    show_unestimated_velocity: bool = False,
) -> MarkerArray:
    """MarkerArray for ``obstacles``: DELETEALL first, then ellipse, circle, arrow, label."""
    out = MarkerArray()
    clear = Marker(action=Marker.DELETEALL)
    clear.header.frame_id = frame_id
    clear.header.stamp = stamp
    out.markers.append(clear)
    lifetime = Duration(seconds=MARKER_LIFETIME).to_msg()

    def marker(ns: str, track_id: int, kind: int) -> Marker:
        m = Marker(ns=ns, id=int(track_id), type=kind, action=Marker.ADD)
        m.header.frame_id = frame_id
        m.header.stamp = stamp
        m.lifetime = lifetime
        m.pose.orientation.w = 1.0
        return m

    for obs in obstacles:
        center = [float(c) for c in obs.center]
        extent = obs.extent if math.isfinite(obs.extent) else INFINITE_EXTENT_DISPLAY
        x, y, z, w = matrix_to_quaternion(ellipse_rotation(obs.plane, obs.orientation))
        body = marker("obstacles", obs.track_id, Marker.CYLINDER)
        body.pose.position = Point(x=center[0], y=center[1], z=center[2])
        body.pose.orientation = Quaternion(x=x, y=y, z=z, w=w)
        body.scale.x, body.scale.y = 2.0 * obs.semi_axes[0], 2.0 * obs.semi_axes[1]
        body.scale.z = float(extent)
        body.color = (
            _color(0.9, 0.4, 0.1, 0.7) if obs.velocity_estimated else _color(0.6, 0.6, 0.6, 0.7)
        )
        out.markers.append(body)

        if inflation > 0.0:
            radius = max(obs.semi_axes) + inflation
            ring = marker("inflated", obs.track_id, Marker.CYLINDER)
            ring.pose.position = Point(x=center[0], y=center[1], z=center[2])
            ring.pose.orientation = body.pose.orientation
            ring.scale.x = ring.scale.y = 2.0 * radius
            ring.scale.z = float(extent) if obs.plane == ObstaclePlane.HORIZONTAL else 0.01
            if obs.plane != ObstaclePlane.HORIZONTAL:
                ring.pose.position.z = 0.005  # a disc on the ground
            ring.color = _color(1.0, 0.1, 0.1, 0.2)
            out.markers.append(ring)

        if obs.velocity_estimated or show_unestimated_velocity:
            arrow = marker("velocity", obs.track_id, Marker.ARROW)
            tip = [c + float(v) for c, v in zip(center, obs.velocity, strict=True)]
            arrow.points = [Point(x=center[0], y=center[1], z=center[2]),
                            Point(x=tip[0], y=tip[1], z=tip[2])]
            arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.03, 0.06, 0.08
            arrow.color = _color(0.1, 0.4, 1.0, 0.9)
            out.markers.append(arrow)

        label = marker("labels", obs.track_id, Marker.TEXT_VIEW_FACING)
        top = center[2] + (0.5 * extent if obs.plane != ObstaclePlane.HORIZONTAL else 0.3)
        label.pose.position = Point(x=center[0], y=center[1], z=top + 0.15)
        speed = f" {obs.speed:.2f} m/s" if obs.velocity_estimated else ""
        label.text = f"{obs.id}{speed}"
        label.scale.z = 0.15
        label.color = _color(1.0, 1.0, 1.0, 1.0)
        out.markers.append(label)
    return out


class ObstacleTrackerNode(Node):
    """Thin rclpy wrapper around the multi-obstacle tracker."""

    def __init__(self, **kwargs) -> None:
        """Create the node; ``kwargs`` go to rclpy's Node (context, parameter_overrides...)."""
        super().__init__("obstacle_tracker", **kwargs)
        ros_common.use_sim_time(self)
        # A bad start-up value raises here (an integer is taken for a float).
        self.params = NodeParameters(self, ObstacleTrackerParams, apply=self._apply_params)
        p = self.params.value
        self.tracker = MultiObstacleTracker(p.tracker)

        self._rejections_before_restart: dict[str, int] = {}
        self._reported_rejections = 0
        self._reported_messages = 0
        self._robot_position: tuple[float, float, float] | None = None
        self._last_detection_time: float | None = None  # receipt time (node clock, sim)
        self._last_marker_time: float | None = None
        self.detection_messages = 0
        self.published = 0
        self.dropped_odom = 0
        self._last_count = 0
        self._publishing = False
        self.last_cycle_time: float | None = None  # sim time of the last timer cycle

        self._pub = ros_common.publisher(self, topics.OBSTACLES)
        self._marker_pub = ros_common.publisher(self, topics.OBSTACLE_MARKERS)
        self._diag_pub = ros_common.publisher(self, topics.DIAGNOSTICS)
        ros_common.subscription(self, topics.OBSTACLE_DETECTIONS, self._on_detections, raw=True)
        self.rejected_messages: dict[str, int] = {}  # whole messages, by reason
        ros_common.subscription(self, topics.ODOM, self._on_odom)
        self._scans = ScanPlacer(p.lidar_mount().matrix())
        self.tracks_cleared = 0
        self.scans_used = 0
        ros_common.subscription(self, topics.SCAN, self._on_scan, raw=True)
        self._timer = self.create_timer(1.0 / float(p.rate), self._on_timer)
        self.create_timer(float(p.diagnostics_period), self._publish_diagnostics)

    # -- parameters ---------------------------------------------------------------------------
    def _apply_params(
        self, old: ObstacleTrackerParams, new: ObstacleTrackerParams, names: frozenset[str]
    ) -> None:
        """Use validated new parameters: a new tracker configuration restarts tracking."""
        if new.tracker != old.tracker:
            self._restart_tracker(new.tracker)
        if new.rate != old.rate:
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / float(new.rate), self._on_timer)

    def _restart_tracker(self, config: TrackerConfig) -> None:
        """Start tracking afresh with ``config``, keeping the rejection counts."""
        self._rejections_before_restart = self.rejection_counts
        self.tracker = MultiObstacleTracker(config)
        self.get_logger().warn("tracker configuration changed: tracking restarted")

    @property
    def rejection_counts(self) -> dict[str, int]:
        """Rejected detections per reason since the node started."""
        counts = dict(self.tracker.rejection_counts)
        for reason, n in self._rejections_before_restart.items():
            counts[reason] = counts.get(reason, 0) + n
        return counts

    # -- inputs -----------------------------------------------------------------------------
    def _now(self) -> float:
        return ros_common.now_seconds(self)

    def _gate(self, max_age: float) -> StampGate:
        return StampGate(float(self.params.value.max_future_stamp), max_age)

    def _reject_message(self, topic: str, reason: str) -> None:
        key = f"{topic}_{reason}"
        self.rejected_messages[key] = self.rejected_messages.get(key, 0) + 1
        self.get_logger().warn(
            f"rejected a {topic} message: {reason}", throttle_duration_sec=2.0
        )

    def _on_odom(self, msg: Odometry) -> None:
        if not ros_common.odometry_is_finite(msg):
            self.dropped_odom += 1
            self.get_logger().warn("dropped an /odom with NaN/Inf", throttle_duration_sec=1.0)
            return
        stamp = ros_common.from_time_msg(msg.header.stamp)
        verdict = self._gate(float(self.params.value.detections_timeout)).verdict(
            stamp, self._now()
        )
        if verdict is not StampVerdict.OK:
            self._reject_message("odom", verdict.value)
            return
        p, v = msg.pose.pose.position, msg.twist.twist.linear
        self._robot_position = (p.x, p.y, p.z)
        if self.params.value.tracker.scan_clearing:  # poses only to place scans
            q = msg.pose.pose.orientation
            self._scans.add_pose(stamp, self._robot_position, (q.x, q.y, q.z, q.w))
        self.tracker.observe_robot(self._robot_position, math.hypot(v.x, v.y))

    def _on_detections(self, raw: bytes) -> None:
        if len(raw) > int(self.params.value.max_message_bytes):
            self._reject_message("detections", "too_large")
            return
        msg = deserialize_message(raw, ObstacleArray)
        now = self._now()
        stamp = ros_common.from_time_msg(msg.header.stamp)
        if stamp == 0.0:  # unstamped: take the receipt time
            stamp = now
        verdict = self._gate(float(self.params.value.detections_timeout)).verdict(stamp, now)
        if verdict is not StampVerdict.OK:
            self._reject_message("detections", verdict.value)
            return
        report = self.tracker.update(detections_from_msg(msg), stamp, self._robot_position)
        self.detection_messages += 1
        stale = len(report.rejected) > 0 and report.accepted == 0 and all(
            reason.value == "stale_timestamp" for _, reason in report.rejected
        )
        if not stale:  # a batch the tracker refused for its stamp keeps nothing fresh
            self._last_detection_time = now
        if report.rejected:
            reasons = sorted({reason.value for _, reason in report.rejected})
            self.get_logger().warn(
                f"rejected {len(report.rejected)} detection(s): {', '.join(reasons)}",
                throttle_duration_sec=2.0,
            )
        for track_id in report.deleted:
            self.get_logger().debug(f"track {track_id} deleted")

    def _on_scan(self, raw: bytes) -> None:
        """Clear the coasting tracks this scan sees through (only with ``scan_clearing``)."""
        params = self.params.value
        if not params.tracker.scan_clearing:
            return
        if len(raw) > int(params.max_message_bytes):
            self._reject_message("scan", "too_large")
            return
        try:
            msg = deserialize_message(raw, LaserScan)
        except Exception:  # noqa: BLE001 - any undecodable payload is dropped
            self._reject_message("scan", "undecodable")
            return
        if msg.header.frame_id != params.lidar_frame:
            self._reject_message("scan", "wrong_frame")
            return
        stamp = ros_common.from_time_msg(msg.header.stamp)
        verdict = self._gate(float(params.detections_timeout)).verdict(stamp, self._now())
        if verdict is not StampVerdict.OK:
            self._reject_message("scan", verdict.value)
            return
        seen = self._scans.seen_free(
            stamp, msg.angle_min, msg.angle_increment, np.asarray(msg.ranges, dtype=float),
            msg.range_min, msg.range_max,
        )
        if seen is None:
            self._reject_message("scan", "no_pose")
            return
        self.scans_used += 1
        for track_id in self.tracker.clear_seen_through(seen):
            self.tracks_cleared += 1
            self.get_logger().debug(f"track {track_id} cleared: the scan sees through it")

    # -- output -----------------------------------------------------------------------------
    def detections_stale(self, t: float) -> bool:
        """True when no detection message arrived within ``detections_timeout`` of ``t``."""
        last = self._last_detection_time
        return last is None or t - last > float(self.params.value.detections_timeout)

    def _on_timer(self) -> None:
        t = self._now()
        self.last_cycle_time = t
        if self.detections_stale(t):
            if self._publishing:
                self.get_logger().warn("detections stale: /obstacles no longer published")
                self._publishing = False
            return
        if not self._publishing:
            self.get_logger().info("detections received: publishing /obstacles")
            self._publishing = True
        obstacles = self.tracker.tracks_at(t)
        self._last_count = len(obstacles)
        stamp = ros_common.to_time_msg(t)
        frame_id = str(self.params.value.tracker.frame_id)
        raw_velocity = bool(self.params.value.publish_unestimated_velocity)
        msg = ObstacleArray()
        msg.header.stamp = stamp
        msg.header.frame_id = frame_id
        msg.obstacles = [
            obstacle_to_msg(
                o, velocity_source=Obstacle.VELOCITY_ESTIMATED if o.velocity_estimated
                else Obstacle.VELOCITY_UNKNOWN, send_velocity=o.velocity_estimated or raw_velocity,
            )
            for o in obstacles
        ]
        self._pub.publish(msg)
        self.published += 1

        marker_rate = float(self.params.value.marker_rate)
        if marker_rate > 0.0 and (
            self._last_marker_time is None
            or t - self._last_marker_time >= 1.0 / marker_rate - 1e-6
            or t < self._last_marker_time
        ):
            self._last_marker_time = t
            self._marker_pub.publish(
                obstacle_markers(
                    obstacles, stamp, frame_id, float(self.params.value.marker_inflation),
                    raw_velocity,
                )
            )

    def _publish_diagnostics(self) -> None:
        t = self._now()
        counts = self.rejection_counts
        total = sum(counts.values())
        new_rejections = total - self._reported_rejections
        self._reported_rejections = total
        messages = sum(self.rejected_messages.values())
        new_messages = messages - self._reported_messages
        self._reported_messages = messages
        if self._last_detection_time is None:
            level, text = "warn", "waiting for detections"
        elif self.detections_stale(t):
            level, text = "warn", "detections stale: /obstacles not published"
        elif new_rejections or new_messages:
            level, text = "warn", (
                f"tracking; {new_rejections} detection(s) and {new_messages} message(s) "
                "rejected recently"
            )
        else:
            level, text = "ok", "tracking"
        tracks = self.tracker.tracks
        values = {
            "tracks_confirmed": sum(1 for trk in tracks if trk.confirmed),
            "tracks_tentative": sum(1 for trk in tracks if not trk.confirmed),
            "obstacles_published": self._last_count,
            "maneuvers_detected": self.tracker.maneuver_count,
            "tracks_cleared": self.tracks_cleared,
            "scans_used": self.scans_used,
            "detection_messages": self.detection_messages,
            "rejected_total": total,
            **{f"rejected_{reason}": n for reason, n in counts.items()},
            "dropped_odom": self.dropped_odom,
            "rejected_messages": sum(self.rejected_messages.values()),
            **{f"rejected_{key}": n for key, n in sorted(self.rejected_messages.items())},
        }
        status = ros_common.diagnostic_status("obstacle_tracker", level, text, values)
        self._diag_pub.publish(ros_common.diagnostic_array(self, [status]))


def main(args: list[str] | None = None) -> int:
    """Run the obstacle tracker node as its own process."""
    return ros_common.run_node(ObstacleTrackerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
