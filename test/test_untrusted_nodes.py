"""Fault injection at the node level, in-process: each input topic of the tracker, the safety
filter and the gait controller gets wrong clocks, NaN, a second publisher or a flood; every
case states what the node must do and checks it (no simulator: scripted clock and inputs).
"""

from __future__ import annotations

import math
import time

import numpy as np
import rclpy
from conftest import spin_until, wait_for_discovery
from filter_harness import SimpleRobot
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from test_safety_filter_node import DT, Driver, odometry, twist
from test_tracker_node import Harness, detection

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray, SafetyFilterState

S = SafetyFilterState
WALL = 1.79e9  # a wall-clock stamp (s): what a node without use_sim_time sends


# -- obstacle tracker: /obstacles/detections, /odom ------------------------------------------
def _poison_detections(h: Harness, stamp_s: float, obstacles=()) -> None:
    msg = ObstacleArray()
    msg.header.stamp = ros_common.to_time_msg(stamp_s)
    msg.header.frame_id = topics.ODOM_FRAME
    msg.obstacles = list(obstacles)
    h.det_pub.publish(msg)


def test_wall_clock_detections_cannot_make_real_ones_stale(ros_executor):
    """The reported failure: one wall-stamped frame made every real frame 'stale'."""
    h = Harness(ros_executor)
    for _ in range(10):
        h.tick([detection(2.0, 0.0)])
    for stamp in (WALL, h.ns * 1e-9 + 100.0, h.ns * 1e-9 - 30.0):  # wall, future, past
        _poison_detections(h, stamp)
        for _ in range(3):
            h.tick([detection(2.0, 0.0)])
    h.flush()
    assert len(h.obstacles[-1].obstacles) == 1  # the real obstacle is still tracked
    assert h.node.tracker.rejection_counts["stale_timestamp"] == 0
    assert h.node.rejected_messages == {
        "detections_future_stamp": 2, "detections_stale_stamp": 1
    }


def test_rejected_frames_do_not_keep_obstacles_fresh(ros_executor):
    """A stream of poisoned frames alone must let /obstacles go silent (consumers brake)."""
    h = Harness(ros_executor)
    for _ in range(10):
        h.tick([detection(2.0, 0.0)])
    for _ in range(20):  # 1 s: the real detector died; a misconfigured one goes on
        _poison_detections(h, WALL, [detection(2.0, 0.0)])
        h.tick(None)
    assert h.node.detections_stale(ros_common.now_seconds(h.node))
    h.flush()
    silent = h.node.published
    h.tick(None)
    assert h.node.published == silent


def test_a_gigantic_detection_message_is_rejected_before_decoding(ros_executor):
    h = Harness(ros_executor, max_message_bytes=100_000)
    for _ in range(5):
        h.tick([detection(2.0, 0.0)])
    big = [detection(5.0 + 0.001 * k, 5.0) for k in range(10_000)]
    _poison_detections(h, h.ns * 1e-9, big)
    assert spin_until(
        ros_executor, lambda: h.node.rejected_messages.get("detections_too_large") == 1, 10.0
    )
    h.tick([detection(2.0, 0.0)])
    h.flush()
    assert len(h.obstacles[-1].obstacles) == 1


def test_tracker_odom_from_the_future_is_rejected(ros_executor):
    h = Harness(ros_executor)
    h.tick([detection(2.0, 0.0)])
    bad = Odometry()
    bad.header.stamp = ros_common.to_time_msg(WALL)
    bad.pose.pose.orientation.w = 1.0
    bad.pose.pose.position.x = 100.0
    h.odom_pub.publish(bad)
    assert spin_until(
        ros_executor, lambda: h.node.rejected_messages.get("odom_future_stamp") == 1, 5.0
    )
    assert h.node._robot_position[0] != 100.0


# -- safety filter: /odom, /obstacles, /cmd_vel ----------------------------------------------
def test_filter_odom_from_the_future_neither_counts_nor_stops_the_cycles(ros_executor):
    """Reported: a future /odom moved the node's last-cycle time ahead; cycles stopped."""
    driver = Driver(ros_executor)
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.4), 0.5)
    bad = odometry(robot, WALL)
    driver.odom_pub.publish(bad)
    assert spin_until(
        ros_executor, lambda: driver.filter.rejected["odom_future_stamp"] == 1, 5.0
    )
    states, _ = driver.run(robot, [], VelocityCommand(0.4), 0.3)  # cycles go on at t
    assert len(states) >= 10 and states[-1].status != S.STALE_INPUT


def test_filter_obstacles_from_the_future_are_rejected_and_the_robot_brakes(ros_executor):
    driver = Driver(ros_executor, obstacles_timeout=0.2)
    robot = SimpleRobot(vx=0.4)
    driver.run(robot, [], VelocityCommand(0.4), 0.4)
    t = 0.4
    speeds = []
    for _ in range(40):  # only future-stamped obstacle lists from now on
        t += DT
        state = driver.step(t, robot, [], twist(0.4), obstacles_stamp=t + 100.0)
        robot.step(ros_common.twist_to_command(state.filtered), DT)
        speeds.append(state.filtered.linear.x)
    assert driver.filter.rejected["obstacles_future_stamp"] >= 30
    assert state.status == S.STALE_INPUT
    assert speeds[-1] == 0.0  # braked to a stop: never "fresh forever"


def test_filter_rejects_a_topic_with_two_publishers(ros_executor):
    driver = Driver(ros_executor)
    robot = SimpleRobot(vx=0.4)
    driver.run(robot, [], VelocityCommand(0.4), 0.4)
    rogue = rclpy.create_node("rogue_odometry", context=ros_executor.context_for_nodes)
    ros_executor.add_node(rogue)
    pub = rogue.create_publisher(Odometry, topics.ODOM.name, 10)
    assert wait_for_discovery(ros_executor, pub)
    time.sleep(0.3)  # the filter asks the graph at most every 0.2 s
    t = 0.4
    for _ in range(25):  # the timer keeps cycling on the node clock (odometry is rejected)
        t += DT
        pub.publish(odometry(SimpleRobot(x=-5.0), t))  # "the robot is elsewhere"
        driver.publish(t, robot, [], twist(0.4))
        spin_until(ros_executor, lambda: False, 0.03)
    state = driver.states[-1]
    assert driver.filter.rejected["odom_second_publisher"] > 0
    assert state.status == S.STALE_INPUT and state.filtered.linear.x < 0.4
    rogue.destroy_node()


def test_filter_caps_obstacles_nearest_first_and_keeps_its_rate_under_a_flood(ros_executor):
    driver = Driver(ros_executor)
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.3), 0.2)
    near = Obstacle(id="near", plane=Obstacle.VERTICAL, semi_axis_a=0.3, semi_axis_b=0.3,
                    extent=1.0)
    near.center.x, near.center.z = 1.5, 0.5
    crowd = [near] + [
        Obstacle(id=f"far{k}", plane=Obstacle.VERTICAL, semi_axis_a=0.2, semi_axis_b=0.2,
                 extent=1.0) for k in range(499)
    ]
    for k, o in enumerate(crowd[1:]):
        o.center.x, o.center.y = -20.0 - 0.01 * k, 30.0
    t = 0.2
    states = []
    for _ in range(10):
        t += DT
        for _ in range(20):  # a burst of 20 lists per cycle (1 kHz at 50 Hz cycles)
            driver.publish(t, robot, crowd, None, odom=False)
        states.append(driver.step(t, robot, crowd, twist(0.3)))
    assert len(states) == 10  # one cycle per step, whatever the flood
    assert "near" in states[-1].obstacle_ids
    limit = driver.filter.cycle.params.max_obstacles
    assert len(states[-1].obstacle_ids) == limit
    # At most two lists decoded per cycle, one on arrival and the newest at the cycle (the
    # others are superseded before decoding).
    decoded = driver.filter.rejected["obstacles_over_max_obstacles"] / (500 - limit)
    assert 5 <= decoded <= 2 * (driver.filter.cycles - 10)


def test_filter_rejects_a_gigantic_obstacle_message_undecoded(ros_executor):
    driver = Driver(ros_executor, max_message_bytes=50_000)
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.3), 0.2)
    crowd = [Obstacle(id=f"o{k}", semi_axis_a=0.2, semi_axis_b=0.2, extent=1.0)
             for k in range(5000)]
    driver.publish(0.2 + DT, robot, crowd, None, odom=False)
    assert spin_until(
        ros_executor, lambda: driver.filter.rejected["obstacles_too_large"] == 1, 5.0
    )


def test_filter_nan_reference_flood_keeps_the_last_good_reference(ros_executor):
    driver = Driver(ros_executor)
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.3), 0.3)
    nan = twist(float("nan"))
    for _ in range(200):
        driver.ref_pub.publish(nan)
        ros_executor.spin_once(timeout_sec=0.0)
    assert spin_until(ros_executor, lambda: driver.filter.dropped["cmd_vel"] >= 50, 10.0)
    state = driver.step(0.3 + DT, robot, [], None)
    assert math.isfinite(state.filtered.linear.x) and state.filtered.linear.x > 0.0


# -- gait controller: /cmd_vel_safe, /imu, /joint_states, /odom --------------------------------
def test_gait_controller_stops_on_two_command_publishers(ros_executor):
    from safe_legged_c3bf.nodes.gait_controller_node import GaitControllerNode

    ctx = ros_executor.context_for_nodes
    node = GaitControllerNode(context=ctx)
    ros_executor.add_node(node)
    io = rclpy.create_node("cmd_sources", context=ctx)
    ros_executor.add_node(io)
    first = io.create_publisher(Twist, topics.CMD_VEL_SAFE.name, 10)
    assert wait_for_discovery(ros_executor, first)
    first.publish(twist(0.3))
    assert spin_until(ros_executor, lambda: node._command.vx == 0.3, 5.0)
    second = io.create_publisher(Twist, topics.CMD_VEL_SAFE.name, 10)
    assert spin_until(ros_executor, lambda: node.count_publishers(topics.CMD_VEL_SAFE.name) == 2)
    time.sleep(0.3)
    second.publish(twist(0.8))
    assert spin_until(
        ros_executor, lambda: node.rejected["cmd_vel_safe_second_publisher"] >= 1, 5.0
    )
    assert node._command == VelocityCommand()  # ambiguous source: stop and stand
    first.publish(twist(0.3))
    assert spin_until(
        ros_executor, lambda: node.rejected["cmd_vel_safe_second_publisher"] >= 2, 5.0
    )
    assert node._command == VelocityCommand()


def test_gait_controller_rejects_state_stamped_by_another_clock(ros_executor):
    from sensor_msgs.msg import Imu, JointState

    from safe_legged_c3bf.nodes.gait_controller_node import GaitControllerNode

    ctx = ros_executor.context_for_nodes
    node = GaitControllerNode(context=ctx)
    ros_executor.add_node(node)
    io = rclpy.create_node("state_sources", context=ctx)
    ros_executor.add_node(io)
    imu_pub = io.create_publisher(Imu, topics.IMU.name, 10)
    joints_pub = io.create_publisher(JointState, topics.JOINT_STATES.name, 10)
    for pub in (imu_pub, joints_pub):
        assert wait_for_discovery(ros_executor, pub)
    imu = Imu()
    imu.orientation.w = 1.0
    imu.header.stamp = ros_common.to_time_msg(WALL)
    joints = JointState(name=["a"], position=[0.0])
    joints.header.stamp = ros_common.to_time_msg(WALL)
    imu_pub.publish(imu)
    joints_pub.publish(joints)
    assert spin_until(
        ros_executor,
        lambda: node.rejected["imu_future_stamp"] == 1
        and node.rejected["joint_states_future_stamp"] == 1, 5.0,
    )
    assert node._imu is None and node._joints is None
    assert np.isinf(node._last_processed_stamp)  # its time was never moved ahead
