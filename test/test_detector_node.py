"""The obstacle detector node in-process: scripted /clock, /odom, /scan and /points in."""

from __future__ import annotations

import math

import numpy as np
import rclpy
from conftest import spin_until, wait_for_discovery
from detector_scenes import Bar, Pillar, Pose, cloud, scan, scan_angles
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan, PointCloud2, PointField

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.sensor_mounts import DEPTH_FRAME, LIDAR_FRAME, default_mounts
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.obstacle_detector_node import ObstacleDetectorNode
from safe_legged_c3bf.nodes.obstacle_tracker_node import detections_from_msg
from safe_legged_c3bf.perception import TrackerConfig, validate_detection
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray

START = 20.0
STEP = 0.1  # s between scans


def scan_msg(ranges, stamp, frame=LIDAR_FRAME) -> LaserScan:
    msg = LaserScan()
    msg.header.stamp = ros_common.to_time_msg(stamp)
    msg.header.frame_id = frame
    msg.angle_min, msg.angle_increment = scan_angles(len(ranges))
    msg.angle_max = msg.angle_min + msg.angle_increment * (len(ranges) - 1)
    msg.range_min, msg.range_max = 0.05, 10.0
    msg.ranges = [float(r) for r in ranges]
    return msg


def cloud_msg(grid, stamp, frame=DEPTH_FRAME, fields="xyz") -> PointCloud2:
    """An organised float32 cloud (height, width, 3); ``fields`` names the channels."""
    msg = PointCloud2()
    msg.header.stamp = ros_common.to_time_msg(stamp)
    msg.header.frame_id = frame
    msg.height, msg.width = grid.shape[0], grid.shape[1]
    msg.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                  for i, n in enumerate(fields)]
    msg.point_step, msg.row_step = 12, 12 * grid.shape[1]
    msg.is_bigendian, msg.is_dense = False, False
    msg.data = np.ascontiguousarray(grid, dtype="<f4").tobytes()
    return msg


def odom_msg(pose: Pose, stamp: float, frame=topics.ODOM_FRAME) -> Odometry:
    msg = Odometry()
    msg.header.stamp = ros_common.to_time_msg(stamp)
    msg.header.frame_id, msg.child_frame_id = frame, topics.BASE_FRAME
    p = msg.pose.pose
    p.position.x, p.position.y, p.position.z = pose.x, pose.y, pose.z
    q = pose.quaternion()
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = q
    return msg


class Harness:
    """A detector node and a scripted test node on one executor."""

    def __init__(self, executor, **overrides) -> None:
        ctx = executor.context_for_nodes
        params = [Parameter("diagnostics_period", value=0.2)]
        params += [Parameter(k, value=v) for k, v in overrides.items()]
        self.node = ObstacleDetectorNode(context=ctx, parameter_overrides=params)
        self.io = rclpy.create_node("detector_test_io", context=ctx)
        self.executor = executor
        executor.add_node(self.node)
        executor.add_node(self.io)

        def pub(topic):
            return self.io.create_publisher(topic.msg_class(), topic.name, ros_common.qos(topic))

        self.clock_pub, self.odom_pub = pub(topics.CLOCK), pub(topics.ODOM)
        self.scan_pub, self.points_pub = pub(topics.SCAN), pub(topics.POINTS)
        self.detections: list[ObstacleArray] = []
        self.diagnostics: list[DiagnosticArray] = []
        for topic, out in ((topics.OBSTACLE_DETECTIONS, self.detections),
                           (topics.DIAGNOSTICS, self.diagnostics)):
            self.io.create_subscription(topic.msg_class(), topic.name, out.append,
                                        ros_common.qos(topic))
        used = {"both": (self.scan_pub, self.points_pub), "scan": (self.scan_pub,),
                "cloud": (self.points_pub,)}[overrides.get("sensors", "both")]
        for p in (self.clock_pub, self.odom_pub, *used, self.node._pub, self.node._diag_pub):
            assert wait_for_discovery(executor, p)

    def clock(self, t: float) -> None:
        self.clock_pub.publish(Clock(clock=ros_common.to_time_msg(t)))
        assert spin_until(
            self.executor, lambda: abs(ros_common.now_seconds(self.node) - t) < 1e-6, 5.0
        )

    def odom(self, msg: Odometry) -> None:
        before = len(self.node.poses) + sum(self.node.rejected.values())
        self.odom_pub.publish(msg)
        assert spin_until(self.executor, lambda: len(self.node.poses)
                          + sum(self.node.rejected.values()) > before, 5.0)

    def send(self, publisher, msg) -> None:
        """Publish a sensor message and spin until the node used or dropped it."""
        count = self.node.scans + self.node.clouds + sum(self.node.rejected.values())
        publisher.publish(msg)
        assert spin_until(self.executor, lambda: self.node.scans + self.node.clouds
                          + sum(self.node.rejected.values()) > count, 5.0)

    def received(self, n: int) -> list[ObstacleArray]:
        assert spin_until(self.executor, lambda: len(self.detections) >= n, 5.0)
        return self.detections

    def diagnostic_values(self, key: str) -> dict[str, str] | None:
        for arr in reversed(self.diagnostics):
            for status in arr.status:
                values = {kv.key: kv.value for kv in status.values}
                if status.name == "obstacle_detector" and key in values:
                    return values
        return None


def test_scan_cloud_and_odom_in_detections_in_odom_out(ros_executor):
    h = Harness(ros_executor)
    mounts = default_mounts("quadruped")
    pose = Pose(x=1.0, y=-0.5, z=0.28, yaw=0.2)
    scene = [Pillar(3.5, 0.3, 0.3), Bar(2.2, z=0.35, radius=0.05)]
    t = START
    h.clock(t)
    for k in range(3):  # odometry before and at the sensor stamps
        h.odom(odom_msg(pose, t - 0.02 * (2 - k)))
    h.send(h.points_pub, cloud_msg(cloud(pose, mounts[DEPTH_FRAME], scene), t))
    h.send(h.scan_pub, scan_msg(scan(pose, mounts[LIDAR_FRAME], scene), t))
    [msg] = h.received(1)
    assert msg.header.frame_id == topics.ODOM_FRAME
    assert ros_common.from_time_msg(msg.header.stamp) == START
    assert h.node.fused == 1
    vertical = [o for o in msg.obstacles if o.plane == Obstacle.VERTICAL]
    horizontal = [o for o in msg.obstacles if o.plane == Obstacle.HORIZONTAL]
    [pillar] = vertical
    assert math.hypot(pillar.center.x - 3.5, pillar.center.y - 0.3) < 0.05
    [bar] = horizontal
    assert abs(bar.center.x - 2.2) < 0.08
    assert 0.25 <= bar.center.z - bar.semi_axis_b <= 0.302
    for o in msg.obstacles:
        assert o.id == "" and o.velocity_source == Obstacle.VELOCITY_UNKNOWN
        assert (o.velocity.x, o.velocity.y, o.velocity.z) == (0.0, 0.0, 0.0)
        assert np.all(np.isfinite(o.position_covariance))
    tracker = TrackerConfig()  # the tracker takes every detection as it comes
    for d in detections_from_msg(msg):
        assert validate_detection(d, frame_id=tracker.frame_id, max_range=tracker.max_range,
                                  max_semi_axis=tracker.max_semi_axis) is None

    # Published at the scan rate: each new scan is one message, fused with the latest cloud.
    t += STEP
    h.clock(t)
    h.odom(odom_msg(pose, t))
    h.send(h.scan_pub, scan_msg(scan(pose, mounts[LIDAR_FRAME], scene), t))
    assert len(h.received(2)) == 2 and h.node.fused == 2
    t += 3 * STEP  # the cloud is now too old to fuse: the scan alone
    h.clock(t)
    h.odom(odom_msg(pose, t))
    h.send(h.scan_pub, scan_msg(scan(pose, mounts[LIDAR_FRAME], scene), t))
    assert len(h.received(3)) == 3 and h.node.fused == 2
    assert h.node.rejected == {}

    def warned():
        for arr in reversed(h.diagnostics):
            for status in arr.status:
                if status.name == "obstacle_detector":
                    return "scan alone" in status.message
        return False

    h.clock(t + 0.25)  # the diagnostics timer runs on sim time
    assert spin_until(ros_executor, warned, 5.0)


def test_bad_inputs_are_dropped_with_a_diagnostic(ros_executor):
    h = Harness(ros_executor, sensors="both")
    mounts = default_mounts("quadruped")
    pose, scene = Pose(), [Pillar(3.0, 0.0, 0.3)]
    ranges = scan(pose, mounts[LIDAR_FRAME], scene)
    t = START
    h.clock(t)
    h.send(h.scan_pub, scan_msg(ranges, t))  # before any odometry
    h.odom(odom_msg(pose, t, frame="map"))  # odometry in the wrong frame
    h.odom(odom_msg(Pose(x=math.nan), t))
    h.odom(odom_msg(pose, t))
    h.send(h.scan_pub, scan_msg(ranges, t, frame="laser"))  # wrong frame
    h.send(h.scan_pub, scan_msg(ranges, t + 5.0))  # from the future
    h.send(h.scan_pub, scan_msg(ranges, t - 2.0))  # stale
    bad = scan_msg(ranges, t)
    bad.angle_increment = math.nan
    h.send(h.scan_pub, bad)
    grid = cloud(pose, mounts[DEPTH_FRAME], scene)
    h.send(h.points_pub, cloud_msg(grid[..., :2].copy(), t, fields="xy"))  # no z
    assert h.node.published == 0
    expected = {
        "scan_no_odom": 1, "odom_wrong_frame": 1, "odom_non_finite": 1,
        "scan_wrong_frame": 1, "scan_future_stamp": 1, "scan_stale_stamp": 1,
        "scan_malformed": 1, "points_malformed": 1,
    }
    assert dict(h.node.rejected) == expected

    def reported():
        values = h.diagnostic_values("rejected_points_malformed")
        return values is not None and values

    h.clock(t + 0.25)  # the diagnostics timer runs on sim time
    assert spin_until(ros_executor, reported, 5.0)
    values = reported()
    for key, n in expected.items():
        assert values[f"rejected_{key}"] == str(n)
    assert values["published"] == "0"

    # NaN and Inf ranges are ordinary: a good scan with some is published.
    ranges = ranges.copy()
    ranges[::7], ranges[3::11] = math.nan, -math.inf
    h.send(h.scan_pub, scan_msg(ranges, t))
    [msg] = h.received(1)
    [o] = msg.obstacles
    assert math.hypot(o.center.x - 3.0, o.center.y) < 0.06
    arrays = [kv for arr in h.diagnostics for st in arr.status for kv in st.values]
    assert arrays  # the node reported all along without crashing


def test_a_lidar_only_robot(ros_executor):
    h = Harness(ros_executor, sensors="scan", robot_kind="biped")
    mounts = default_mounts("biped")
    pose = Pose(z=0.81)
    t = START
    h.clock(t)
    h.odom(odom_msg(pose, t))
    walker = Pillar(2.0, -0.5, 0.2, 1.7)
    h.points_pub.publish(cloud_msg(cloud(pose, mounts[DEPTH_FRAME], [walker]), t))
    h.send(h.scan_pub, scan_msg(scan(pose, mounts[LIDAR_FRAME], [walker]), t))
    [msg] = h.received(1)
    [o] = msg.obstacles
    assert o.plane == Obstacle.VERTICAL
    assert math.hypot(o.center.x - 2.0, o.center.y + 0.5) < 0.05
    assert h.node.clouds == 0 and h.node.fused == 0


def test_the_bar_memory_in_the_node(ros_executor):
    h = Harness(ros_executor)
    mounts = default_mounts("quadruped")
    scene = [Bar(2.5, z=0.35, radius=0.05)]
    t, before = START, Pose(x=1.0, z=0.28)
    h.clock(t)
    h.odom(odom_msg(before, t))
    h.send(h.points_pub, cloud_msg(cloud(before, mounts[DEPTH_FRAME], scene), t))
    h.send(h.scan_pub, scan_msg(scan(before, mounts[LIDAR_FRAME], scene), t))
    assert len(h.node.detector.memory) == 1
    # A live change of a detector parameter keeps the memory; an invalid one is refused.
    assert h.node.set_parameters([Parameter("bar_memory", value=5.0)])[0].successful
    assert h.node.detector.config.bar_memory == 5.0 and len(h.node.detector.memory) == 1
    result = h.node.set_parameters([Parameter("bar_memory", value=-1.0)])[0]
    assert not result.successful and "bar_memory" in result.reason
    # Under the bar, the scan alone (the cloud is too old to fuse): still a bar, no wall.
    under = Pose(x=2.2, z=0.22)
    t += 0.5
    h.clock(t)
    h.odom(odom_msg(under, t))
    h.send(h.scan_pub, scan_msg(scan(under, mounts[LIDAR_FRAME], scene), t))
    msg = h.received(2)[-1]
    assert h.node.fused == 1
    assert [o.plane for o in msg.obstacles] == [Obstacle.HORIZONTAL]
    assert abs(msg.obstacles[0].center.x - 2.5) < 0.06
    # The clock goes back (a new run): the pose history and the bars are forgotten.
    t = START - 5.0
    h.clock(t)
    h.odom_pub.publish(odom_msg(under, t))
    assert spin_until(ros_executor, lambda: h.node.poses.newest == t, 5.0)
    assert len(h.node.poses) == 1 and len(h.node.detector.memory) == 0
