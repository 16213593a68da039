"""Obstacle detector node: /scan, /points and /odom -> /obstacles/detections.

A thin wrapper around :class:`~safe_legged_c3bf.perception.detector.ObstacleDetector`. There
is no tf2: base_link -> sensor comes from the mounts (the robot kind's, or the ``*_xyz`` /
``*_rpy`` overrides, ``perception/detector_params.py``) and odom -> base_link from a short
history of ``/odom`` poses interpolated to each message's stamp.

With ``sensors: both`` every scan is published, fused with the latest cloud when their
stamps are at most ``cloud_max_age`` apart (so at the scan rate); ``scan`` ignores /points,
``cloud`` ignores /scan and publishes at the cloud rate. Each ObstacleArray is stamped with
the sensor's stamp, in ``odom_frame``, with no ids and zero velocities (VELOCITY_UNKNOWN):
the tracker associates and estimates velocities.

The detector remembers the bars the 3-D sensor detected for ``bar_memory`` s (sensor stamps,
``perception/bar_memory.py``), so that the LiDAR's cut through a bar the cloud no longer sees
(under it) is not a wall. A live change of a detector parameter keeps that memory; an /odom
stamp older than the pose history (the clock went back: a new run) clears both.

Untrusted inputs never crash the node; they are dropped and counted by ``<topic>_<reason>``
in /diagnostics: a message larger than ``max_message_bytes`` (before decoding), a wrong
``frame_id`` (or, for /odom, child frame), a stamp more than ``max_future_stamp`` ahead of or
``max_sensor_age`` behind the node's clock, non-finite odometry, malformed scan geometry or
cloud layout, and a sensor stamp the odometry history cannot place (``no_odom`` before the
first /odom, ``before_odom`` older than the history, ``after_odom`` newer than the newest
pose by more than ``max_pose_extrapolation``). NaN/Inf ranges and points are ordinary
(REP-117, organised clouds) and simply left out.
"""

from __future__ import annotations

import math
import time
from collections import Counter, deque
from dataclasses import dataclass

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import LaserScan, PointCloud2

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.messages import (
    laser_scan_points,
    obstacle_to_msg,
    point_cloud_xyz,
)
from safe_legged_c3bf.nodes.parameters import NodeParameters
from safe_legged_c3bf.perception.detector import DetectionReport, ObstacleDetector
from safe_legged_c3bf.perception.detector_params import ObstacleDetectorParams
from safe_legged_c3bf.perception.pose_history import PoseHistory
from safe_legged_c3bf.perception.sensor_frame import SensorFrame, make_frame
from safe_legged_c3bf.perception.sensor_points import SensorInputError
from safe_legged_c3bf.safety import StampGate, StampVerdict
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray

#: Detection times kept for the diagnostics' median and maximum.
TIMING_WINDOW = 200


@dataclass
class _Cloud:
    """The latest accepted cloud: its points in the sensor frame, its frame once made."""

    stamp: float
    points: np.ndarray
    frame: SensorFrame | None = None


class ObstacleDetectorNode(Node):
    """Thin rclpy wrapper around the obstacle detector (see the module doc)."""

    def __init__(self, **kwargs) -> None:
        """Create the node; ``kwargs`` go to rclpy's Node (context, parameter_overrides...)."""
        super().__init__("obstacle_detector", **kwargs)
        ros_common.use_sim_time(self)
        # A bad start-up value raises here, naming the parameter.
        self.params = NodeParameters(self, ObstacleDetectorParams, apply=self._apply_params)
        p = self.params.value
        self.lidar_mount, self.cloud_mount = p.mounts()
        self._lidar_T = self.lidar_mount.matrix()  # the mounts are fixed at start-up
        self._cloud_T = self.cloud_mount.matrix()
        self._gate = StampGate(float(p.max_future_stamp), float(p.max_sensor_age))
        self.self_box = p.self_box()
        self.detector = ObstacleDetector(p.detector)
        self.poses = PoseHistory(p.pose_history, p.max_pose_extrapolation)
        self._cloud: _Cloud | None = None
        self.rejected: Counter[str] = Counter()  # "<topic>_<reason>" -> messages
        self._reported_rejections = 0
        self.scans = self.clouds = self.published = self.fused = 0
        self._last_fused = False
        self.last_report: DetectionReport | None = None
        self._detect_ms: deque[float] = deque(maxlen=TIMING_WINDOW)

        self._pub = ros_common.publisher(self, topics.OBSTACLE_DETECTIONS)
        self._diag_pub = ros_common.publisher(self, topics.DIAGNOSTICS)
        ros_common.subscription(self, topics.ODOM, self._on_odom)
        if p.sensors in ("both", "scan"):
            ros_common.subscription(self, topics.SCAN, self._on_scan, raw=True)
        if p.sensors in ("both", "cloud"):
            ros_common.subscription(self, topics.POINTS, self._on_points, raw=True)
        self.create_timer(float(p.diagnostics_period), self._publish_diagnostics)
        self.get_logger().info(
            f"sensors {p.sensors}; {self.lidar_mount.frame_id} at {self.lidar_mount.xyz} "
            f"rpy {self.lidar_mount.rpy}, {self.cloud_mount.frame_id} at {self.cloud_mount.xyz}"
            f" rpy {self.cloud_mount.rpy} (base_link); self box {self.self_box}"
        )

    # -- parameters ---------------------------------------------------------------------------
    def _apply_params(
        self, old: ObstacleDetectorParams, new: ObstacleDetectorParams, names: frozenset[str]
    ) -> None:
        """Use validated new parameters: the detector's (its bar memory kept), the pose hold."""
        if new.detector != old.detector:
            self.detector.configure(new.detector)
        self.poses.max_extrapolation = float(new.max_pose_extrapolation)
        self._gate = StampGate(float(new.max_future_stamp), float(new.max_sensor_age))

    # -- inputs -------------------------------------------------------------------------------
    def _now(self) -> float:
        return ros_common.now_seconds(self)

    def _reject(self, topic: str, reason: str, detail: str = "") -> None:
        key = f"{topic}_{reason}"
        self.rejected[key] += 1
        self.get_logger().warn(
            f"dropped a /{topic} message: {reason}{': ' + detail if detail else ''}",
            throttle_duration_sec=2.0,
        )

    def _stamp_ok(self, topic: str, stamp: float) -> bool:
        verdict = self._gate.verdict(stamp, self._now())
        if verdict is not StampVerdict.OK:
            self._reject(topic, verdict.value, f"stamp {stamp:.3f} s, clock {self._now():.3f} s")
            return False
        return True

    def _on_odom(self, msg: Odometry) -> None:
        p = self.params.value
        if not ros_common.odometry_is_finite(msg):
            self._reject("odom", "non_finite")
            return
        if msg.header.frame_id != p.odom_frame or msg.child_frame_id != p.base_frame:
            self._reject(
                "odom", "wrong_frame", f"{msg.header.frame_id!r} -> {msg.child_frame_id!r}"
            )
            return
        stamp = ros_common.from_time_msg(msg.header.stamp)
        if not self._stamp_ok("odom", stamp):
            return
        pose = msg.pose.pose
        position = (pose.position.x, pose.position.y, pose.position.z)
        q = pose.orientation
        newest = self.poses.newest
        if newest is not None and stamp < newest - float(p.pose_history):
            self.poses.clear()  # the clock went back (a new run): start a new history
            self.detector.clear()  # and forget the bars of the old run's odom
        if not self.poses.add(stamp, position, (q.x, q.y, q.z, q.w)):
            self._reject("odom", "out_of_order")

    def _decode(self, raw: bytes, topic: str, cls: type, frame_id: str) -> object | None:
        """The message of ``raw`` if it is small enough, in ``frame_id`` and timely."""
        if len(raw) > int(self.params.value.max_message_bytes):
            self._reject(topic, "too_large", f"{len(raw)} bytes")
            return None
        try:
            msg = deserialize_message(raw, cls)
        except Exception as err:  # noqa: BLE001 - any undecodable payload is dropped
            self._reject(topic, "undecodable", str(err))
            return None
        if msg.header.frame_id != frame_id:
            self._reject(topic, "wrong_frame", f"{msg.header.frame_id!r}, expected {frame_id!r}")
            return None
        if not self._stamp_ok(topic, ros_common.from_time_msg(msg.header.stamp)):
            return None
        return msg

    def _on_scan(self, raw: bytes) -> None:
        msg = self._decode(raw, "scan", LaserScan, self.lidar_mount.frame_id)
        if msg is None:
            return
        stamp = ros_common.from_time_msg(msg.header.stamp)
        try:
            sp = laser_scan_points(msg)
            frame = make_frame(
                "scan", stamp, sp.points, self._lidar_T, self.poses,
                self.self_box, sp.beam_times, sp.beams, msg.angle_increment, sp.beam_count,
            )
        except SensorInputError as err:
            self._reject("scan", err.reason, str(err))
            return
        self.scans += 1
        cloud = self._cloud_for(stamp) if self.params.value.sensors == "both" else None
        self._detect_and_publish(stamp, frame, cloud)

    def _on_points(self, raw: bytes) -> None:
        msg = self._decode(raw, "points", PointCloud2, self.cloud_mount.frame_id)
        if msg is None:
            return
        stamp = ros_common.from_time_msg(msg.header.stamp)
        try:
            points = point_cloud_xyz(msg)
        except SensorInputError as err:
            self._reject("points", err.reason, str(err))
            return
        if self._cloud is not None and stamp < self._cloud.stamp:
            self._reject("points", "out_of_order")
            return
        self.clouds += 1
        self._cloud = _Cloud(stamp, points)
        if self.params.value.sensors == "cloud":
            frame = self._cloud_for(stamp)
            if frame is not None:
                self._detect_and_publish(stamp, None, frame)

    def _cloud_for(self, stamp: float) -> SensorFrame | None:
        """The latest cloud in odom if within ``cloud_max_age`` of ``stamp``, else None.

        The frame is made once, at the first scan that uses it: by then the odometry of its
        stamp has usually arrived.
        """
        cloud = self._cloud
        if cloud is None or abs(cloud.stamp - stamp) > float(self.params.value.cloud_max_age):
            return None
        if cloud.frame is None:
            try:
                cloud.frame = make_frame(
                    "cloud", cloud.stamp, cloud.points, self._cloud_T, self.poses,
                    self.self_box,
                )
            except SensorInputError as err:
                if err.reason != "after_odom" or self.params.value.sensors == "cloud":
                    self._reject("points", err.reason, str(err))
                    self._cloud = None
                return None
        return cloud.frame

    # -- output -------------------------------------------------------------------------------
    def _detect_and_publish(
        self, stamp: float, scan: SensorFrame | None, cloud: SensorFrame | None
    ) -> None:
        start = time.perf_counter()
        try:
            report = self.detector.detect(scan=scan, cloud=cloud)
        except Exception as err:  # noqa: BLE001 - a detector failure drops one frame only
            self.rejected["detector_error"] += 1
            self.get_logger().error(f"detection failed: {err!r}", throttle_duration_sec=2.0)
            return
        self._detect_ms.append(1e3 * (time.perf_counter() - start))
        self._last_fused = scan is not None and cloud is not None
        self.fused += int(self._last_fused)
        self.last_report = report
        msg = ObstacleArray()
        msg.header.stamp = ros_common.to_time_msg(stamp)
        msg.header.frame_id = str(self.params.value.odom_frame)
        msg.obstacles = [
            obstacle_to_msg(o, velocity_source=Obstacle.VELOCITY_UNKNOWN, send_velocity=False)
            for o in report.obstacles
        ]
        self._pub.publish(msg)
        self.published += 1

    def _publish_diagnostics(self) -> None:
        p = self.params.value
        total = sum(self.rejected.values())
        new = total - self._reported_rejections
        self._reported_rejections = total
        if self.poses.newest is None:
            level, text = "warn", "waiting for /odom"
        elif self.published == 0:
            level, text = "warn", f"waiting for {'/points' if p.sensors == 'cloud' else '/scan'}"
        elif new:
            level, text = "warn", f"detecting; {new} message(s) dropped recently"
        elif p.sensors == "both" and not self._last_fused:
            level, text = "warn", (
                "detecting from the scan alone: no /points within cloud_max_age (overhead "
                "obstacles the scan plane cuts are reported as vertical, unless in a bar "
                "remembered for bar_memory)"
            )
        else:
            level, text = "ok", "detecting"
        report = self.last_report or DetectionReport()
        timing = np.array(self._detect_ms) if self._detect_ms else np.full(1, math.nan)
        values = {
            "sensors": p.sensors,
            "scans": self.scans,
            "clouds": self.clouds,
            "published": self.published,
            "fused_with_cloud": self.fused,
            "obstacles": len(report.obstacles),
            "horizontal_clusters": report.horizontal_clusters,
            "remembered_bars": report.remembered_bars,
            "bar_points_absorbed": report.absorbed,
            "points": report.points,
            "candidates": report.candidates,
            "detect_ms_median": f"{float(np.median(timing)):.3f}",
            "detect_ms_max": f"{float(np.max(timing)):.3f}",
            "rejected_total": total,
            **{f"rejected_{key}": n for key, n in sorted(self.rejected.items())},
        }
        status = ros_common.diagnostic_status("obstacle_detector", level, text, values)
        self._diag_pub.publish(ros_common.diagnostic_array(self, [status]))


def main(args: list[str] | None = None) -> int:
    """Run the obstacle detector node as its own process."""
    return ros_common.run_node(ObstacleDetectorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
