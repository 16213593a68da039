"""The reference planner node in-process, closing the loop through a kinematic robot.

The test publishes /clock and /odom itself and integrates the /cmd_vel it gets back.
"""

from __future__ import annotations

import math

import pytest
import rclpy
import yaml
from conftest import spin_until, wait_for_discovery
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.reference_planner_node import ReferencePlannerNode
from safe_legged_c3bf.planning.params import ReferencePlannerParams
from safe_legged_c3bf.planning.reference_planner import PlannerMode
from safe_legged_c3bf.run.config import config_path

STEP_NS = 20_000_000  # 50 Hz: one /cmd_vel per clock step
START_NS = 1_000_000_000


class KinematicLoop:
    """A planner node and a unicycle-with-lateral-slide robot integrated in the test."""

    def __init__(self, executor, **overrides) -> None:
        ctx = executor.context_for_nodes
        params = [Parameter(k, value=v) for k, v in overrides.items()]
        self.node = ReferencePlannerNode(context=ctx, parameter_overrides=params)
        self.io = rclpy.create_node("planner_test_io", context=ctx)
        self.executor = executor
        executor.add_node(self.node)
        executor.add_node(self.io)
        self.clock_pub = self.io.create_publisher(
            Clock, topics.CLOCK.name, ros_common.qos(topics.CLOCK)
        )
        self.odom_pub = self.io.create_publisher(
            Odometry, topics.ODOM.name, ros_common.qos(topics.ODOM)
        )
        self.goal_pub = self.io.create_publisher(
            PoseStamped, topics.GOAL_POSE.name, ros_common.qos(topics.GOAL_POSE)
        )
        self.commands: list[Twist] = []
        self.io.create_subscription(
            Twist, topics.CMD_VEL.name, self.commands.append, ros_common.qos(topics.CMD_VEL)
        )
        for pub in (self.clock_pub, self.odom_pub, self.goal_pub, self.node._pub):
            assert wait_for_discovery(executor, pub)
        self.ns = START_NS
        self.x, self.y, self.yaw, self.z = 0.0, 0.0, 0.0, 0.25

    def step(self, odom: bool = True) -> Twist:
        """Advance one step: publish clock (and odometry), get the command, integrate it."""
        self.ns += STEP_NS
        if odom:
            msg = Odometry()
            msg.header.stamp = ros_common.to_time_msg(self.ns * 1e-9)
            msg.header.frame_id = topics.ODOM_FRAME
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            p.x, p.y, p.z = self.x, self.y, self.z
            q.z, q.w = math.sin(self.yaw / 2), math.cos(self.yaw / 2)
            self.odom_pub.publish(msg)
            # The odometry first, so that the cycle of this step sees it.
            assert spin_until(
                self.executor,
                lambda: self.node._odom_time is not None
                and abs(self.node._odom_time - self.ns * 1e-9) < 1e-6,
                5.0,
            )
        count = self.node.cycles
        self.clock_pub.publish(Clock(clock=ros_common.to_time_msg(self.ns * 1e-9)))
        assert spin_until(
            self.executor,
            lambda: self.node.cycles > count and len(self.commands) >= self.node.cycles,
            5.0,
        )
        cmd = self.commands[-1]
        dt = STEP_NS * 1e-9
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        self.x += (cmd.linear.x * c - cmd.linear.y * s) * dt
        self.y += (cmd.linear.x * s + cmd.linear.y * c) * dt
        self.z += cmd.linear.z * dt
        self.yaw += cmd.angular.z * dt
        return cmd

    def send_goal(self, x: float, y: float, frame: str = topics.ODOM_FRAME, yaw=None) -> None:
        """Publish a /goal_pose and spin until the node has handled it."""
        msg = PoseStamped()
        msg.header.frame_id = frame
        msg.header.stamp = ros_common.to_time_msg(self.ns * 1e-9)
        msg.pose.position.x, msg.pose.position.y = x, y
        if yaw is not None and not math.isfinite(yaw):
            msg.pose.orientation.z = yaw  # a broken quaternion
        elif yaw is None:
            msg.pose.orientation.w = 0.0  # all-zero quaternion: any final heading
        else:
            msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        handled = self.node.accepted_goals + self.node.rejected_goals
        self.goal_pub.publish(msg)
        assert spin_until(
            self.executor,
            lambda: self.node.accepted_goals + self.node.rejected_goals > handled,
            5.0,
        )


def is_zero(cmd: Twist, vertical: bool = True) -> bool:
    values = [cmd.linear.x, cmd.linear.y, cmd.angular.z] + ([cmd.linear.z] if vertical else [])
    return all(v == 0.0 for v in values)


def test_drives_to_the_goal_from_goal_pose_and_stops(ros_executor):
    loop = KinematicLoop(ros_executor)
    # No odometry yet: zero.
    assert is_zero(loop.step(odom=False))
    # Odometry but no goal: holds still, only the height controller acts.
    cmd = loop.step()
    assert is_zero(cmd, vertical=False) and cmd.linear.z > 0.0  # 0.25 m < z_nominal 0.28

    loop.send_goal(1.2, 0.6, yaw=0.5)
    assert loop.node.accepted_goals == 1
    for _ in range(600):
        loop.step()
        if loop.node.planner.arrived:
            break
    assert loop.node.planner.arrived
    assert math.hypot(loop.x - 1.2, loop.y - 0.6) <= 0.05 + 1e-3
    assert abs(loop.yaw - 0.5) <= 0.05 + 1e-3
    assert loop.z == pytest.approx(0.28, abs=0.01)
    for _ in range(10):  # stays stopped
        assert is_zero(loop.step(), vertical=False)
    distance = loop.node.distance_to_goal()
    assert distance is not None and distance <= 0.051

    # Malformed goals are ignored: NaN, wrong frame, non-finite orientation.
    loop.send_goal(math.nan, 1.0)
    loop.send_goal(3.0, 0.0, frame="base_link")
    loop.send_goal(3.0, 0.0, yaw=math.inf)
    assert loop.node.rejected_goals == 3
    goal = loop.node.planner.goal
    assert (goal.x, goal.y) == (1.2, 0.6)
    for _ in range(5):
        assert is_zero(loop.step(), vertical=False)

    # Odometry stops: zero once it is older than odom_timeout (0.5 s).
    loop.send_goal(2.0, 0.6)
    assert not is_zero(loop.step(), vertical=False)
    stale = [loop.step(odom=False) for _ in range(30)]
    assert not is_zero(stale[0], vertical=False)  # 20 ms old: still fresh
    assert all(is_zero(c) for c in stale[26:])  # > 0.5 s old
    assert loop.node._state == "odometry_stale"


def test_constant_velocity_mode(ros_executor):
    loop = KinematicLoop(
        ros_executor, mode="constant_velocity", constant_vx=0.3, constant_vy=-0.1,
        constant_yaw_rate=0.2,
    )
    loop.z = 0.28
    loop.send_goal(-5.0, 0.0)  # kept but unused
    for _ in range(5):
        cmd = loop.step()
        assert (cmd.linear.x, cmd.linear.y, cmd.angular.z) == pytest.approx((0.3, -0.1, 0.2))
        assert cmd.linear.z == pytest.approx(2.0 * (0.28 - loop.z + cmd.linear.z * 0.02), abs=1e-6)
    assert loop.x > 0.0
    # A scripted vertical speed replaces the height hold.
    result = loop.node.set_parameters([Parameter("constant_vz", value=-0.1)])[0]
    assert result.successful, result.reason
    assert loop.step().linear.z == pytest.approx(-0.1)


def test_scenario_sets_mode_goal_and_speed(ros_executor):
    ctx = ros_executor.context_for_nodes
    node = ReferencePlannerNode(
        context=ctx, parameter_overrides=[Parameter("scenario", value="quadruped_default")]
    )
    ros_executor.add_node(node)
    cfg = node.planner.config
    assert cfg.mode is PlannerMode.GOAL and cfg.max_vx == pytest.approx(0.4)
    assert (node.planner.goal.x, node.planner.goal.y) == (7.0, 0.0)
    assert node.get_parameter("goal_x").value == 7.0  # the parameters show what is used

    node2 = ReferencePlannerNode(
        context=ctx, parameter_overrides=[Parameter("scenario", value="test_minimal")]
    )
    ros_executor.add_node(node2)
    assert node2.planner.config.mode is PlannerMode.CONSTANT_VELOCITY
    assert node2.planner.config.constant_velocity == (0.3, 0.0, 0.0)
    assert node2.get_parameter("mode").value == "constant_velocity"

    with pytest.raises(ValueError, match="no_such_scenario"):
        ReferencePlannerNode(
            context=ctx, parameter_overrides=[Parameter("scenario", value="no_such_scenario")]
        )


def test_invalid_parameters_are_rejected_with_the_reason(ros_executor):
    node = ReferencePlannerNode(context=ros_executor.context_for_nodes)
    ros_executor.add_node(node)
    cases = {
        "mode": ("fly", "mode"),
        "max_vx": (-0.5, "max_vx"),
        "k_speed": (3.0, "k_speed"),  # >= k_heading: the robot may orbit
        "resume_distance": (0.01, "resume_distance"),  # <= goal_tolerance
        "rate": (0.0, "rate"),
        "odom_timeout": (math.nan, "odom_timeout"),
        "constant_vx": (2.0, "constant_velocity"),  # above max_vx
        "scenario": ("quadruped_default", "scenario"),
        "max_linear_accel": (-1.0, "max_linear_accel"),
        "goal_x": ("far", "goal_x"),
    }
    for name, (value, word) in cases.items():
        before = node.get_parameter(name).value
        result = node.set_parameters([Parameter(name, value=value)])[0]
        assert not result.successful, name
        assert word in result.reason, (name, result.reason)
        after = node.get_parameter(name).value
        assert after == before or (math.isnan(after) and math.isnan(before))
    # Valid changes are applied (an int for a float parameter too); the goal parameters set
    # a goal.
    assert node.set_parameters([Parameter("max_vx", value=1)])[0].successful
    assert node.planner.config.max_vx == 1
    results = node.set_parameters([Parameter("goal_x", value=2.0), Parameter("goal_y", value=-1.0)])
    assert all(r.successful for r in results)
    assert (node.planner.goal.x, node.planner.goal.y) == (2.0, -1.0)
    assert node.set_parameters([Parameter("mode", value="holonomic")])[0].successful
    assert node.planner.config.mode is PlannerMode.HOLONOMIC
    assert node.planner.goal is not None  # kept across the reconfiguration


def test_startup_rejects_an_invalid_configuration(ros_executor):
    with pytest.raises(ValueError, match="k_heading"):
        ReferencePlannerNode(
            context=ros_executor.context_for_nodes,
            parameter_overrides=[Parameter("k_heading", value=0.5)],
        )


def test_defaults_equal_the_config_file(ros_executor):
    data = yaml.safe_load(config_path("reference_planner.yaml").read_text())
    params = data["reference_planner"]["ros__parameters"]
    defaults = ReferencePlannerParams.defaults()
    assert set(params) == set(defaults)
    node = ReferencePlannerNode(context=ros_executor.context_for_nodes)
    ros_executor.add_node(node)
    for name, value in params.items():
        for actual in (defaults[name], node.get_parameter(name).value):
            assert type(actual) is type(value), name
            if isinstance(value, float) and math.isnan(value):
                assert math.isnan(actual), name
            else:
                assert actual == value, name
