"""The gait controller node in an in-process executor with scripted sensors."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rclpy
from conftest import spin_until, wait_for_discovery
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.gait_controller_node import GaitControllerNode
from safe_legged_c3bf.sim.robots import robot_spec
from safe_legged_c3bf_msgs.msg import MotorCommand


class Sensors:
    def __init__(self, executor, **params):
        ctx = executor.context_for_nodes
        self.node_under_test = GaitControllerNode(
            context=ctx, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()]
        )
        n = rclpy.create_node("gait_test_sensors", context=ctx)
        executor.add_node(self.node_under_test)
        executor.add_node(n)
        self.executor = executor
        self.clock = n.create_publisher(Clock, topics.CLOCK.name, 10)
        self.imu = n.create_publisher(Imu, topics.IMU.name, 10)
        self.joints = n.create_publisher(JointState, topics.JOINT_STATES.name, 10)
        self.odom = n.create_publisher(Odometry, topics.ODOM.name, 10)
        self.cmd = n.create_publisher(Twist, topics.CMD_VEL_SAFE.name, 10)
        self.commands: list[MotorCommand] = []
        self.diagnostics: list[DiagnosticArray] = []
        n.create_subscription(MotorCommand, topics.JOINT_COMMANDS.name, self.commands.append, 50)
        n.create_subscription(DiagnosticArray, topics.DIAGNOSTICS.name, self.diagnostics.append, 10)
        for pub in (self.clock, self.imu, self.joints, self.odom, self.cmd):
            assert wait_for_discovery(executor, pub)
        spec = robot_spec("a1")
        self.names = list(spec.standing_pose)
        self.q = [spec.standing_pose[j] for j in self.names]

    def publish_state(self, t, joints_t=None, imu_nan=False):
        stamp = ros_common.to_time_msg(t)
        self.clock.publish(Clock(clock=stamp))
        odom = Odometry()
        odom.header.stamp = stamp
        odom.pose.pose.position.z = 0.28
        odom.pose.pose.orientation.w = 1.0
        self.odom.publish(odom)
        imu = Imu()
        imu.header.stamp = stamp
        imu.orientation.w = float("nan") if imu_nan else 1.0
        self.imu.publish(imu)
        js = JointState()
        js.header.stamp = ros_common.to_time_msg(t if joints_t is None else joints_t)
        js.name, js.position, js.velocity = self.names, self.q, [0.0] * len(self.q)
        self.joints.publish(js)

    def wait_for_command(self, t, timeout=5.0):
        def got():
            return any(
                abs(ros_common.from_time_msg(c.header.stamp) - t) < 1e-9 for c in self.commands
            )
        return spin_until(self.executor, got, timeout)


@pytest.fixture
def sensors(ros_executor):
    return Sensors(ros_executor, robot="quadruped", command_timeout=0.5)


def test_commands_are_stamped_with_the_state_they_answer(sensors):
    period = sensors.node_under_test.controller.control_period
    for k in range(5):
        t = 1.0 + k * period
        sensors.publish_state(t)
        assert sensors.wait_for_command(t), f"no MotorCommand for the state at {t}"
    cmd = sensors.commands[-1]
    assert list(cmd.name) == sensors.node_under_test.controller.joint_names
    assert len(cmd.q) == len(cmd.kp) == len(cmd.tau) == 12
    assert all(math.isfinite(v) for v in (*cmd.q, *cmd.tau))


def test_no_tick_faster_than_the_control_period(sensors):
    period = sensors.node_under_test.controller.control_period
    sensors.publish_state(2.0)
    assert sensors.wait_for_command(2.0)
    sensors.publish_state(2.0 + 0.25 * period)
    spin_until(sensors.executor, lambda: False, timeout=0.3)
    assert not sensors.wait_for_command(2.0 + 0.25 * period, timeout=0.2)


def test_a_republished_state_gets_its_command_again(sensors):
    # The simulator republishes its t = 0 state while it waits for the first command; if
    # the first answer was lost (publisher not yet matched), the next republication must
    # be answered again, or simulator and controller wait for each other for good.
    sensors.publish_state(0.0)
    assert sensors.wait_for_command(0.0)
    spin_until(sensors.executor, lambda: False, timeout=0.3)
    assert len(sensors.commands) == 1  # one answer per state, not one per sensor message
    first = sensors.commands[0]
    sensors.publish_state(0.0)
    assert spin_until(sensors.executor, lambda: len(sensors.commands) >= 2, 5.0)
    spin_until(sensors.executor, lambda: False, timeout=0.3)
    assert len(sensors.commands) == 2  # once per republication
    again = sensors.commands[1]
    assert again.header.stamp == first.header.stamp
    assert list(again.q) == list(first.q) and list(again.tau) == list(first.tau)
    # Time going on is answered as usual, once per state.
    period = sensors.node_under_test.controller.control_period
    sensors.publish_state(period)
    assert sensors.wait_for_command(period)
    spin_until(sensors.executor, lambda: False, timeout=0.3)
    assert len(sensors.commands) == 3


def test_first_command_waits_for_the_expected_readers(ros_executor):
    # With --record the recorder also reads /joint_commands; physics starts with the first
    # command, so it is held (the simulator keeps republishing its t = 0 state) until the
    # recorder has matched, or the recording misses the start (or, on a slow machine, all).
    sensors = Sensors(ros_executor, robot="quadruped", start_subscribers=2, start_wait=30.0)
    sensors.publish_state(0.0)
    assert not sensors.wait_for_command(0.0, timeout=1.0)
    late = rclpy.create_node("gait_test_recorder", context=ros_executor.context_for_nodes)
    ros_executor.add_node(late)
    recorded: list[MotorCommand] = []
    late.create_subscription(MotorCommand, topics.JOINT_COMMANDS.name, recorded.append, 50)
    assert spin_until(
        ros_executor, lambda: sensors.node_under_test._pub.get_subscription_count() >= 2, 10.0
    )
    sensors.publish_state(0.0)  # the simulator's next republication
    assert sensors.wait_for_command(0.0)
    assert spin_until(ros_executor, lambda: len(recorded) >= 1, 5.0)


def test_first_command_hold_is_bounded(ros_executor):
    sensors = Sensors(ros_executor, robot="quadruped", start_subscribers=3, start_wait=0.5)
    sensors.publish_state(0.0)
    assert not sensors.wait_for_command(0.0, timeout=0.2)
    spin_until(ros_executor, lambda: False, timeout=0.5)
    sensors.publish_state(0.0)
    assert sensors.wait_for_command(0.0)  # started anyway, with a warning


def test_mismatched_or_nan_states_are_not_acted_on(sensors):
    sensors.publish_state(3.0, joints_t=2.9)  # halves of different states
    assert not sensors.wait_for_command(3.0, timeout=0.5)
    sensors.publish_state(3.1, imu_nan=True)
    assert not sensors.wait_for_command(3.1, timeout=0.5)
    assert spin_until(sensors.executor, lambda: sensors.node_under_test._dropped >= 1, 5.0)


def test_command_timeout_stops_and_stands(sensors):
    ctrl = sensors.node_under_test
    twist = Twist()
    twist.linear.x = 0.4
    sensors.publish_state(5.0)
    sensors.cmd.publish(twist)
    assert spin_until(sensors.executor, lambda: ctrl._command.vx == 0.4, 5.0)
    sensors.publish_state(5.0 + ctrl.controller.control_period)
    assert sensors.wait_for_command(5.0 + ctrl.controller.control_period)
    assert not ctrl._command_stale
    sensors.publish_state(6.0)  # 1 s later, no new /cmd_vel_safe
    assert sensors.wait_for_command(6.0)
    assert ctrl._command_stale
    assert ctrl._active_command(6.0).is_zero()
    assert spin_until(
        sensors.executor,
        lambda: any(
            s.message.startswith("command stale")
            for d in sensors.diagnostics for s in d.status if s.name == "gait_controller"
        ),
        timeout=5.0,
    )


def test_bad_command_timeout_is_rejected(ros_executor):
    with pytest.raises(ValueError, match="command_timeout"):
        GaitControllerNode(
            context=ros_executor.context_for_nodes,
            parameter_overrides=[Parameter("command_timeout", value=-1.0)],
        )
    node = GaitControllerNode(context=ros_executor.context_for_nodes)
    result = node.set_parameters([Parameter("command_timeout", value=0.0)])[0]
    assert not result.successful and "command_timeout" in result.reason
    node.destroy_node()


def test_unknown_robot_is_a_clear_error(ros_executor):
    with pytest.raises(ValueError, match="unknown robot"):
        GaitControllerNode(
            context=ros_executor.context_for_nodes,
            parameter_overrides=[Parameter("robot", value="hexapod")],
        )


def test_biped_controller_loads(ros_executor):
    node = GaitControllerNode(
        context=ros_executor.context_for_nodes,
        parameter_overrides=[Parameter("robot", value="biped")],
    )
    assert len(node.controller.joint_names) == 12
    assert np.isclose(node.controller.control_period, 0.005)
    node.destroy_node()
