"""The obstacle tracker node in-process: scripted /clock, /odom and detections in, tracks out."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rclpy
import yaml
from conftest import spin_until, wait_for_discovery
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.rotations import matrix_to_quaternion
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.obstacle_tracker_node import ObstacleTrackerNode, ellipse_rotation
from safe_legged_c3bf.perception import ObstaclePlane
from safe_legged_c3bf.perception.params import ObstacleTrackerParams
from safe_legged_c3bf.run.config import config_path
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray

STEP_NS = 50_000_000  # 20 Hz detections and tracker rate: one publish per clock step
START_NS = 1_000_000_000


def _stamp(ns: int):
    return ros_common.to_time_msg(ns * 1e-9)


class Harness:
    """A tracker node plus a scripted test node on one executor."""

    def __init__(self, executor, **overrides) -> None:
        ctx = executor.context_for_nodes
        params = [Parameter("rate", value=20.0)]
        params += [Parameter(k, value=v) for k, v in overrides.items()]
        self.node = ObstacleTrackerNode(context=ctx, parameter_overrides=params)
        self.io = rclpy.create_node("tracker_test_io", context=ctx)
        self.executor = executor
        executor.add_node(self.node)
        executor.add_node(self.io)
        self.clock_pub = self.io.create_publisher(
            Clock, topics.CLOCK.name, ros_common.qos(topics.CLOCK)
        )
        self.det_pub = self.io.create_publisher(
            ObstacleArray, topics.OBSTACLE_DETECTIONS.name,
            ros_common.qos(topics.OBSTACLE_DETECTIONS),
        )
        self.odom_pub = self.io.create_publisher(
            Odometry, topics.ODOM.name, ros_common.qos(topics.ODOM)
        )
        self.obstacles: list[ObstacleArray] = []
        self.markers: list[MarkerArray] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.io.create_subscription(
            ObstacleArray, topics.OBSTACLES.name, self.obstacles.append,
            ros_common.qos(topics.OBSTACLES),
        )
        self.io.create_subscription(
            MarkerArray, topics.OBSTACLE_MARKERS.name, self.markers.append,
            ros_common.qos(topics.OBSTACLE_MARKERS),
        )
        self.io.create_subscription(
            DiagnosticArray, topics.DIAGNOSTICS.name, self.diagnostics.append,
            ros_common.qos(topics.DIAGNOSTICS),
        )
        for pub in (self.clock_pub, self.det_pub, self.odom_pub):
            assert wait_for_discovery(executor, pub)
        for pub in (self.node._pub, self.node._marker_pub, self.node._diag_pub):
            assert wait_for_discovery(executor, pub)
        self.ns = START_NS

    def tick(self, obstacles: list[Obstacle] | None, robot=(0.0, 0.0)) -> None:
        """Advance the clock one step; publish odometry and (unless None) detections."""
        self.ns += STEP_NS
        self.clock_pub.publish(Clock(clock=_stamp(self.ns)))
        odom = Odometry()
        odom.header.stamp = _stamp(self.ns)
        odom.header.frame_id = topics.ODOM_FRAME
        odom.pose.pose.position.x, odom.pose.pose.position.y = robot
        odom.pose.pose.orientation.w = 1.0
        self.odom_pub.publish(odom)
        now = self.ns * 1e-9

        def cycled() -> bool:
            last = self.node.last_cycle_time
            return last is not None and abs(last - now) < 1e-6

        if obstacles is None:
            assert spin_until(self.executor, cycled, 5.0)
            return
        msg = ObstacleArray()
        msg.header.stamp = _stamp(self.ns)
        msg.header.frame_id = topics.ODOM_FRAME
        msg.obstacles = obstacles
        count = self.node.detection_messages
        self.det_pub.publish(msg)
        assert spin_until(
            self.executor, lambda: self.node.detection_messages > count and cycled(), 5.0
        )

    def flush(self) -> None:
        """Spin until every /obstacles message the node published has been received."""
        assert spin_until(self.executor, lambda: len(self.obstacles) >= self.node.published, 5.0)


def detection(x, y, z=0.5, a=0.3, b=0.2, plane=Obstacle.VERTICAL, extent=1.0, ident=""):
    o = Obstacle(id=ident, plane=plane, semi_axis_a=a, semi_axis_b=b, extent=extent)
    o.center.x, o.center.y, o.center.z = float(x), float(y), float(z)
    return o


def test_moving_obstacle_is_tracked_with_velocity_and_markers(ros_executor):
    h = Harness(ros_executor)
    rng = np.random.default_rng(3)
    p0, v = np.array([2.0, -1.0]), np.array([0.3, 0.4])
    for k in range(60):  # 3 s of 20 Hz detections, 2 cm noise
        t = k * STEP_NS * 1e-9
        p = p0 + v * t + rng.normal(0.0, 0.02, 2)
        h.tick([detection(*p), detection(5.0, 5.0, a=0.4, b=0.4)])
    h.flush()
    last = h.obstacles[-1]
    assert last.header.frame_id == topics.ODOM_FRAME
    assert ros_common.from_time_msg(last.header.stamp) == pytest.approx(h.ns * 1e-9, abs=1e-6)
    assert len(last.obstacles) == 2
    moving = min(last.obstacles, key=lambda o: math.hypot(o.center.x - 3.0, o.center.y - 0.0))
    still = max(last.obstacles, key=lambda o: math.hypot(o.center.x - 3.0, o.center.y - 0.0))
    assert moving.velocity_source == Obstacle.VELOCITY_ESTIMATED
    assert moving.velocity.x == pytest.approx(0.3, abs=0.08)
    assert moving.velocity.y == pytest.approx(0.4, abs=0.08)
    t_last = (h.ns - START_NS - STEP_NS) * 1e-9  # the truth at the stamp of the last message
    truth = p0 + v * t_last
    assert math.hypot(moving.center.x - truth[0], moving.center.y - truth[1]) < 0.08
    assert math.hypot(still.velocity.x, still.velocity.y) < 0.08
    assert (moving.semi_axis_a, moving.semi_axis_b, moving.extent) == (0.3, 0.2, 1.0)
    cov = np.array(moving.velocity_covariance).reshape(3, 3)
    assert np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(cov) > 0)
    assert np.all(np.isfinite(moving.position_covariance))
    assert moving.id.startswith("track_")

    assert spin_until(ros_executor, lambda: len(h.markers) > 0, 5.0)
    markers = h.markers[-1].markers
    assert markers[0].action == Marker.DELETEALL
    kinds = {(m.ns, m.type) for m in markers[1:]}
    assert ("obstacles", Marker.CYLINDER) in kinds
    assert ("velocity", Marker.ARROW) in kinds
    assert ("labels", Marker.TEXT_VIEW_FACING) in kinds
    labels = {m.text.split()[0] for m in markers if m.type == Marker.TEXT_VIEW_FACING}
    assert labels == {o.id for o in last.obstacles}

    # The detector stops: /obstacles goes silent once the detections are stale.
    for _ in range(12):
        h.tick(None)
    h.flush()
    silent_from = h.node.published
    for _ in range(5):
        h.tick(None)
    assert h.node.published == silent_from
    assert h.node.detections_stale(ros_common.now_seconds(h.node))


def test_nan_detections_are_counted_not_published(ros_executor):
    h = Harness(ros_executor, diagnostics_period=0.5)
    bad = detection(math.nan, 1.0)
    for k in range(25):
        x = 1.0 + 0.01 * k
        h.tick([detection(x, 0.0, ident="pillar"), bad, detection(2.0, 2.0, a=-0.1)])
    h.flush()
    counts = h.node.rejection_counts
    assert counts["non_finite"] == 25
    assert counts["non_positive_size"] == 25
    for msg in h.obstacles:
        for o in msg.obstacles:
            assert o.id == "pillar"
            assert all(math.isfinite(c) for c in (o.center.x, o.center.y, o.center.z))
    assert [o.id for o in h.obstacles[-1].obstacles] == ["pillar"]

    def reported():
        for arr in reversed(h.diagnostics):
            for status in arr.status:
                values = {kv.key: kv.value for kv in status.values}
                rejected = values.get("rejected_non_finite", "0")
                if status.name == "obstacle_tracker" and rejected != "0":
                    return values
        return None

    assert spin_until(ros_executor, lambda: reported() is not None, 5.0)
    values = reported()
    assert int(values["rejected_non_finite"]) > 0
    assert int(values["tracks_confirmed"]) == 1


def test_horizontal_bar_marker_lies_along_y():
    R = ellipse_rotation(ObstaclePlane.HORIZONTAL, 0.3)
    np.testing.assert_allclose(R @ [0, 0, 1], [0, 1, 0], atol=1e-12)  # cylinder axis = odom y
    np.testing.assert_allclose(R @ [1, 0, 0], [math.cos(0.3), 0, math.sin(0.3)], atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    x, y, z, w = matrix_to_quaternion(R)
    # Rebuild the matrix from the quaternion and compare.
    Q = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    np.testing.assert_allclose(Q, R, atol=1e-12)
    R = ellipse_rotation(ObstaclePlane.VERTICAL, 1.0)
    assert matrix_to_quaternion(R) == pytest.approx((0, 0, math.sin(0.5), math.cos(0.5)))


def test_invalid_parameters_are_rejected_with_the_reason(ros_executor):
    node = ObstacleTrackerNode(context=ros_executor.context_for_nodes)
    ros_executor.add_node(node)
    cases = {
        "confirm_hits": 0,
        "confirm_window": 2,  # < confirm_hits
        "gate_probability": 1.5,
        "max_range": -1.0,
        "measurement_std": math.nan,
        "rate": 0.0,
        "marker_rate": -1.0,
        "frame_id": "",
        "accel_psd": "high",
    }
    for name, value in cases.items():
        before = node.get_parameter(name).value
        result = node.set_parameters([Parameter(name, value=value)])[0]
        assert not result.successful, name
        assert name in result.reason, (name, result.reason)
        assert node.get_parameter(name).value == before
    assert node.set_parameters([Parameter("diagnostics_period", value=2.0)])[0].reason
    # Valid values are taken (an int for a float parameter too).
    assert node.set_parameters([Parameter("max_range", value=8)])[0].successful
    assert node.tracker.config.max_range == 8
    assert node.set_parameters([Parameter("confirm_hits", value=2)])[0].successful
    assert node.tracker.config.track.confirm_hits == 2
    assert node.set_parameters([Parameter("rate", value=10.0)])[0].successful


def test_startup_rejects_an_invalid_configuration(ros_executor):
    with pytest.raises(ValueError, match="velocity_std_threshold"):
        ObstacleTrackerNode(
            context=ros_executor.context_for_nodes,
            parameter_overrides=[Parameter("velocity_std_threshold", value=-0.1)],
        )


def _same(a: object, b: object) -> bool:
    """Equal, with NaN equal to NaN and a list equal to a tuple of the same items."""
    if isinstance(a, (list, tuple)) or hasattr(a, "tolist"):
        a, b = list(a), list(b)
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_defaults_equal_the_config_file(ros_executor):
    data = yaml.safe_load(config_path("obstacle_tracker.yaml").read_text())
    params = data["obstacle_tracker"]["ros__parameters"]
    defaults = ObstacleTrackerParams.defaults()
    assert params.keys() == defaults.keys()
    for name, value in params.items():
        assert _same(value, defaults[name]), name
    node = ObstacleTrackerNode(context=ros_executor.context_for_nodes)
    ros_executor.add_node(node)
    for name, value in params.items():
        assert _same(node.get_parameter(name).value, value), name


@pytest.mark.parametrize("clearing", [True, False], ids=["clearing", "no_clearing"])
def test_a_scan_that_sees_through_a_coasting_track_deletes_it(ros_executor, clearing):
    """With scan_clearing, /scan beams through a lost track's place delete it early."""
    h = Harness(ros_executor, scan_clearing=clearing)
    scan_pub = h.io.create_publisher(LaserScan, topics.SCAN.name, ros_common.qos(topics.SCAN))
    assert wait_for_discovery(ros_executor, scan_pub)
    for _ in range(10):
        h.tick([detection(1.5, 0.0)])
    lost = h.ns * 1e-9
    for _ in range(30):  # 1.5 s of empty batches and scans that reach 3 m all around
        h.tick([])
        scan = LaserScan(angle_min=-math.pi, angle_increment=2.0 * math.pi / 360,
                         range_min=0.1, range_max=8.0, ranges=[3.0] * 360)
        scan.header.stamp = _stamp(h.ns)
        scan.header.frame_id = "lidar_link"
        used = h.node.scans_used
        scan_pub.publish(scan)
        if clearing:
            assert spin_until(ros_executor, lambda u=used: h.node.scans_used > u, 5.0)
    h.flush()
    shown = [ros_common.from_time_msg(m.header.stamp) for m in h.obstacles if m.obstacles]
    gone_after = max(shown) - lost
    if clearing:  # clear_after 0.25 s, then two scans
        assert gone_after < 0.5 and h.node.tracks_cleared == 1
    else:  # max_coast_time
        assert gone_after >= 0.9 and h.node.scans_used == 0
