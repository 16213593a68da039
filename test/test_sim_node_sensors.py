"""The simulator node with ``perception.source: sensors``: /scan and /points, no detections."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from conftest import spin_until, wait_for_discovery
from sensor_msgs.msg import LaserScan, PointCloud2, PointField
from test_sim_node import Probe, make_node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.sensor_mounts import DEPTH_FRAME, LIDAR_FRAME
from safe_legged_c3bf.nodes.ros_common import from_time_msg, qos
from safe_legged_c3bf.nodes.simulator.sensor_publisher import empty_cloud, fill_cloud
from safe_legged_c3bf.run.config import config_path


def sensors_scenario(tmp_path, duration: float) -> str:
    scenario = yaml.safe_load(config_path("scenarios", "test_minimal.yaml").read_text())
    scenario.update(duration=duration, name="sensors")
    scenario["perception"].update(source="sensors", lidar={"rate": 20.0},
                                  depth={"rate": 10.0, "columns": 32, "rows": 24})
    path = tmp_path / "sensors.yaml"
    path.write_text(yaml.safe_dump(scenario))
    return str(path)


def cloud_points(msg: PointCloud2) -> np.ndarray:
    return np.frombuffer(bytes(msg.data), dtype="<f4").reshape(-1, 3)


def _run(executor, scenario: str, name: str):
    """A lockstep run; returns (node, the /scan and /points messages received)."""
    node = make_node(executor, scenario=scenario, real_time_factor=0.0, lockstep=True,
                     lockstep_timeout=5.0)
    probe = Probe(executor, node, name=name)
    got = {"scan": [], "points": []}
    probe.node.create_subscription(LaserScan, topics.SCAN.name, got["scan"].append,
                                   qos(topics.SCAN))
    probe.node.create_subscription(PointCloud2, topics.POINTS.name, got["points"].append,
                                   qos(topics.POINTS))
    assert wait_for_discovery(executor, probe.pub)
    assert spin_until(executor, lambda: probe.node.count_publishers(topics.POINTS.name) == 1
                      and probe.node.count_publishers(topics.SCAN.name) == 1, 10)
    probe.answer = True  # every state, the repeated one at t = 0 first, gets its command
    assert spin_until(executor, lambda: node.finished, 40)
    sim = node.simulation
    spin_until(executor, lambda: len(got["scan"]) == sim.lidar.casts
               and len(got["points"]) == sim.depth.casts, 5)
    assert probe.node.count_publishers(topics.OBSTACLE_DETECTIONS.name) == 0
    assert not probe.msgs["detections"]
    return node, probe, got


def test_sensors_mode_publishes_scan_and_points(ros_executor, tmp_path):
    node, probe, got = _run(ros_executor, sensors_scenario(tmp_path, 0.5), "sensors_probe")
    sim = node.simulation
    summary = node.summary()
    assert summary["perception_source"] == "sensors" and summary["detection_frames"] == 0
    assert summary["lidar_scans"] == sim.lidar.casts == 10  # 20 Hz for 0.5 s
    assert summary["depth_clouds"] == sim.depth.casts == 5  # 10 Hz
    # Best effort: a message may be lost on a loaded machine, but not most of them.
    assert len(got["scan"]) >= 8 and len(got["points"]) >= 4
    for msg in got["scan"]:
        t = from_time_msg(msg.header.stamp)
        assert msg.header.frame_id == LIDAR_FRAME
        assert t == pytest.approx(round(t * 20) / 20, abs=1e-9) and 0.0 < t <= 0.5
        assert len(msg.ranges) == 360 and not msg.intensities
        assert msg.angle_min == pytest.approx(-math.pi)
        assert msg.angle_increment == pytest.approx(2 * math.pi / 360)
        assert msg.angle_max == pytest.approx(math.pi - 2 * math.pi / 360)
        assert (msg.range_min, msg.range_max) == pytest.approx((0.1, 8.0))
        assert msg.scan_time == pytest.approx(0.05) and msg.time_increment == 0.0
        ranges = np.array(msg.ranges)
        valid = np.isfinite(ranges)
        assert np.all((ranges[valid] >= 0.1) & (ranges[valid] <= 8.0))
        assert valid.sum() > 5 and np.any(ranges == np.inf)  # the pillar, the mover; open space
    stamps = [from_time_msg(m.header.stamp) for m in got["points"]]
    assert stamps == sorted(stamps)
    for msg in got["points"]:
        t = from_time_msg(msg.header.stamp)
        assert msg.header.frame_id == DEPTH_FRAME
        assert t == pytest.approx(round(t * 10) / 10, abs=1e-9)
        assert [(f.name, f.offset, f.datatype, f.count) for f in msg.fields] == [
            ("x", 0, PointField.FLOAT32, 1), ("y", 4, PointField.FLOAT32, 1),
            ("z", 8, PointField.FLOAT32, 1)]
        assert msg.height == 1 and msg.point_step == 12 and msg.is_dense
        assert msg.row_step == 12 * msg.width == len(msg.data) and not msg.is_bigendian
        points = cloud_points(msg)
        assert len(points) > 100 and np.all(np.isfinite(points))
        norms = np.linalg.norm(points, axis=1)
        assert norms.min() >= 0.2 - 1e-4 and norms.max() <= 6.0 + 1e-4
        assert np.mean(points[:, 2] < -0.1) > 0.3  # the ground, below the level sensor


def test_sensors_mode_lockstep_runs_are_identical(ros_executor, tmp_path):
    path = sensors_scenario(tmp_path, 0.2)
    runs = []
    for i in range(2):
        node, probe, got = _run(ros_executor, path, f"sensors_probe_{i}")
        runs.append({
            "scans": {from_time_msg(m.header.stamp): np.array(m.ranges) for m in got["scan"]},
            "clouds": {from_time_msg(m.header.stamp): cloud_points(m) for m in got["points"]},
            "timeouts": node.lockstep_timeouts,
        })
        for n in (node, probe.node):
            ros_executor.remove_node(n)
            n.destroy_node()
    a, b = runs
    assert a["timeouts"] == b["timeouts"] == 0
    common = set(a["scans"]) & set(b["scans"])
    assert len(common) >= 3
    for t in common:
        assert np.array_equal(a["scans"][t], b["scans"][t], equal_nan=True)
    common = set(a["clouds"]) & set(b["clouds"])
    assert common
    for t in common:
        assert np.array_equal(a["clouds"][t], b["clouds"][t])


def test_cloud_message_layout():
    msg = empty_cloud("depth_link")
    assert msg.width == 0 and msg.row_step == 0 and len(msg.data) == 0
    points = np.array([[1.0, -2.0, 0.5], [3.25, 0.0, -1.0]])
    fill_cloud(msg, points)
    assert msg.width == 2 and msg.row_step == 24 and len(msg.data) == 24
    assert cloud_points(msg) == pytest.approx(points)
