"""MCAP recording: rosbag2-style schemas, raw CDR bytes, readable with mcap_ros2's reader."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest
from conftest import spin_until
from geometry_msgs.msg import Twist
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from message_samples import samples
from rclpy.serialization import serialize_message
from sensor_msgs.msg import LaserScan

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.ros_common import qos
from safe_legged_c3bf.nodes.simulator.sensor_publisher import empty_cloud, fill_cloud
from safe_legged_c3bf.run import msgdefs
from safe_legged_c3bf.run.recorder import McapFile, RecorderNode

SEP = "=" * 80


def read_back(path, topics=None):
    """(topic, log_time_ns, decoded message) of every message, with mcap_ros2's decoder."""
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [
            (channel.topic, message.log_time, msg)
            for _, channel, message, msg in reader.iter_decoded_messages(topics=topics)
        ]


def test_definition_embeds_every_dependency_once():
    text = msgdefs.rosbag2_definition("safe_legged_c3bf_msgs/msg/SafetyFilterState")
    assert text.startswith("# What the C3BF safety filter did in one cycle.")
    for dep in ("std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Twist",
                "geometry_msgs/Vector3"):
        assert text.count(f"{SEP}\nMSG: {dep}\n") == 1, dep
    assert "MSG: safe_legged_c3bf_msgs/SafetyFilterState" not in text


def test_definition_resolves_same_package_types():
    text = msgdefs.rosbag2_definition("safe_legged_c3bf_msgs/msg/ObstacleArray")
    assert f"{SEP}\nMSG: safe_legged_c3bf_msgs/Obstacle\n" in text
    assert f"{SEP}\nMSG: geometry_msgs/Point\n" in text


def test_definition_from_class_when_no_msg_file(monkeypatch):
    monkeypatch.setattr(msgdefs, "find_msg_file", lambda type_name: None)
    msgdefs.msg_text.cache_clear()
    msgdefs.rosbag2_definition.cache_clear()
    try:
        text = msgdefs.rosbag2_definition("safe_legged_c3bf_msgs/msg/Obstacle")
        assert "float64[9] position_covariance" in text
        assert "geometry_msgs/Point center" in text
        assert f"{SEP}\nMSG: geometry_msgs/Point\n" in text
    finally:
        msgdefs.msg_text.cache_clear()
        msgdefs.rosbag2_definition.cache_clear()


def test_every_contract_type_round_trips_through_mcap(tmp_path):
    path = tmp_path / "all.mcap"
    sample = samples()
    by_type = {type(m).__name__: m for m in sample.values()}
    written = {}
    f = McapFile(path, topics.CONTRACT)
    for i, topic in enumerate(topics.CONTRACT):
        msg = by_type.get(topic.type.rsplit("/", 1)[1]) or topic.msg_class()()
        f.write(topic, serialize_message(msg), 1_000 + i, 1_000 + i)
        written[topic.name] = msg
    f.close()

    with open(path, "rb") as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        channels = {c.topic: c for c in summary.channels.values()}
        assert set(channels) == {t.name for t in topics.CONTRACT}
        for topic in topics.CONTRACT:
            channel = channels[topic.name]
            schema = summary.schemas[channel.schema_id]
            assert channel.message_encoding == "cdr"
            assert schema.encoding == "ros2msg"
            assert schema.name == topic.type
    decoded = {topic: msg for topic, _, msg in read_back(path)}
    state = decoded["/c3bf/state"]
    assert state.status_text == "relaxed" and list(state.h) == [0.1, -0.2]
    assert decoded["/ground_truth/safety"].contact_obstacle_ids == ["a"]
    obstacles = decoded["/obstacles"].obstacles
    assert [o.id for o in obstacles] == ["pillar_0", "pillar_1"]
    assert list(obstacles[1].velocity_covariance) == pytest.approx([k * 1e-2 for k in range(9)])


def test_range_sensor_messages_round_trip_through_mcap(tmp_path):
    text = msgdefs.rosbag2_definition(topics.POINTS.type)
    assert text.count(f"{SEP}\nMSG: sensor_msgs/PointField\n") == 1
    scan = LaserScan()
    scan.header.frame_id = "lidar_link"
    scan.header.stamp.sec, scan.header.stamp.nanosec = 3, 100_000_000
    scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = -3.1, 0.5, 0.1, 8.0
    scan.ranges = [1.5, math.inf, -math.inf, math.nan, 7.25]
    points = np.array([[1.0, 0.5, -0.25], [2.0, -0.75, 0.125]], dtype=np.float32)
    cloud = fill_cloud(empty_cloud("depth_link"), points)
    path = tmp_path / "sensors.mcap"
    f = McapFile(path, (topics.SCAN, topics.POINTS))
    f.write(topics.SCAN, serialize_message(scan), 1_000, 1_000)
    f.write(topics.POINTS, serialize_message(cloud), 2_000, 2_000)
    f.close()
    decoded = {topic: msg for topic, _, msg in read_back(path)}
    ranges = decoded["/scan"].ranges
    assert ranges[0] == 1.5 and ranges[1] == math.inf and ranges[2] == -math.inf
    assert math.isnan(ranges[3]) and ranges[4] == 7.25
    assert decoded["/scan"].header.frame_id == "lidar_link"
    back = decoded["/points"]
    assert [f.name for f in back.fields] == ["x", "y", "z"] and back.point_step == 12
    assert back.width == 2 and back.row_step == 24 and back.is_dense
    assert np.array_equal(np.frombuffer(bytes(back.data), "<f4").reshape(-1, 3), points)


def test_recorder_node_writes_what_is_published(ros_executor, tmp_path):
    context = ros_executor.context_for_nodes
    import rclpy

    path = tmp_path / "live.mcap"
    entries = (topics.CMD_VEL_SAFE, topics.FILTER_STATE)
    recorder = RecorderNode(path, entries, context=context)
    talker = rclpy.create_node("talker", context=context)
    ros_executor.add_node(recorder)
    ros_executor.add_node(talker)
    pub = talker.create_publisher(Twist, topics.CMD_VEL_SAFE.name, qos(topics.CMD_VEL_SAFE))
    state_pub = talker.create_publisher(
        topics.FILTER_STATE.msg_class(), topics.FILTER_STATE.name, qos(topics.FILTER_STATE)
    )
    assert spin_until(ros_executor, lambda: pub.get_subscription_count() >= 1
                      and state_pub.get_subscription_count() >= 1, timeout=10)
    for k in range(5):
        msg = Twist()
        msg.linear.x = 0.1 * k
        pub.publish(msg)
    state_pub.publish(
        next(m for m in samples().values() if type(m).__name__ == "SafetyFilterState")
    )
    assert spin_until(
        ros_executor,
        lambda: recorder.file.counts[topics.CMD_VEL_SAFE.name] >= 5
        and recorder.file.counts[topics.FILTER_STATE.name] >= 1,
        timeout=10,
    )
    recorder.close()
    msgs = read_back(path)
    twists = [msg.linear.x for topic, _, msg in msgs if topic == "/cmd_vel_safe"]
    assert twists == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    assert all(log_time > 0 for _, log_time, _ in msgs)
    assert any(topic == "/c3bf/state" for topic, _, _ in msgs)


def test_recorder_process_finishes_file_on_sigint(tmp_path, ros_executor):
    """The recorder run as a process writes a complete (indexed) file when interrupted."""
    import signal
    import subprocess
    import sys

    path = tmp_path / "proc.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-m", "safe_legged_c3bf.run.recorder", str(path),
         "--topics", "/cmd_vel_safe"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    import rclpy

    node = rclpy.create_node("talker2", context=ros_executor.context_for_nodes)
    ros_executor.add_node(node)
    pub = node.create_publisher(Twist, "/cmd_vel_safe", qos(topics.CMD_VEL_SAFE))
    try:
        assert spin_until(ros_executor, lambda: pub.get_subscription_count() >= 1, timeout=15)
        stop = threading.Event()

        def publish() -> None:
            while not stop.is_set():
                pub.publish(Twist())
                time.sleep(0.01)

        thread = threading.Thread(target=publish)
        thread.start()
        time.sleep(0.5)
        stop.set()
        thread.join()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, proc.stderr.read()
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics.message_count > 10
