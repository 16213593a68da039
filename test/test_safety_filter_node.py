"""The safety filter node in an in-process executor, with scripted publishers and a simple
lagging robot closed in lockstep with the node (sim time from a scripted /clock).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import rclpy
from conftest import spin_until, wait_for_discovery
from diagnostic_msgs.msg import DiagnosticArray
from filter_harness import ScriptedObstacle, SimpleRobot, clearance
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.safety_filter_node import SafetyFilterNode
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray, SafetyFilterState

DT = 0.02
Z_NOMINAL = 0.28
S = SafetyFilterState


class Driver:
    """Scripted /clock, /odom, /obstacles and /cmd_vel; records the filter's outputs."""

    def __init__(self, executor, **filter_params):
        ctx = executor.context_for_nodes
        overrides = [Parameter(k, value=v) for k, v in filter_params.items()]
        self.filter = SafetyFilterNode(context=ctx, parameter_overrides=overrides)
        self.node = rclpy.create_node("filter_test_driver", context=ctx)
        executor.add_node(self.filter)
        executor.add_node(self.node)
        self.executor = executor
        n = self.node
        self.clock_pub = n.create_publisher(Clock, topics.CLOCK.name, 10)
        self.odom_pub = n.create_publisher(Odometry, topics.ODOM.name, 10)
        self.obs_pub = n.create_publisher(ObstacleArray, topics.OBSTACLES.name, 10)
        self.ref_pub = n.create_publisher(Twist, topics.CMD_VEL.name, 10)
        self.states: list[SafetyFilterState] = []
        self.commands: list[Twist] = []
        self.diagnostics: list[DiagnosticArray] = []
        n.create_subscription(SafetyFilterState, topics.FILTER_STATE.name, self.states.append, 50)
        n.create_subscription(Twist, topics.CMD_VEL_SAFE.name, self.commands.append, 50)
        n.create_subscription(DiagnosticArray, topics.DIAGNOSTICS.name, self.diagnostics.append, 50)
        for pub in (self.clock_pub, self.odom_pub, self.obs_pub, self.ref_pub):
            assert wait_for_discovery(executor, pub)
        assert spin_until(executor, lambda: self.filter.count_publishers(topics.CLOCK.name) > 0)

    def publish(self, t, robot, obstacles, reference, odom=True, obstacles_stamp=None):
        self.clock_pub.publish(Clock(clock=ros_common.to_time_msg(t)))
        if reference is not None:
            self.ref_pub.publish(reference)
        if obstacles is not None:
            arr = ObstacleArray()
            arr.header.frame_id = "odom"
            stamp = t if obstacles_stamp is None else obstacles_stamp
            arr.header.stamp = ros_common.to_time_msg(stamp)
            arr.obstacles = obstacles
            self.obs_pub.publish(arr)
        if odom:
            self.odom_pub.publish(odometry(robot, t))

    def step(self, t, robot, obstacles, reference, **kw):
        """Publish inputs at t and wait for the filter's cycle with stamp t."""
        n0 = len(self.states)
        self.publish(t, robot, obstacles, reference, **kw)

        def got():
            return any(
                ros_common.from_time_msg(s.header.stamp) >= t - 1e-9 for s in self.states[n0:]
            )

        assert spin_until(self.executor, got, timeout=10.0), f"no filter cycle at t={t:.2f}"
        return self.states[-1]

    def run(self, robot, scripted, reference, duration, hold_height=True):
        """Closed loop: returns the filter states and the min clearance."""
        gaps, states = [], []
        for k in range(int(duration / DT)):
            t = (k + 1) * DT
            ref = reference
            if hold_height:
                ref = twist(ref.vx, ref.vy, 2.0 * (Z_NOMINAL - robot.z), ref.yaw_rate)
            else:
                ref = twist(ref.vx, ref.vy, ref.vz, ref.yaw_rate)
            state = self.step(t, robot, [obstacle_msg(o, t) for o in scripted], ref)
            states.append(state)
            cmd = ros_common.twist_to_command(state.filtered)
            for _ in range(10):
                robot.step(cmd, DT / 10)
            gaps += [clearance(robot, o, t + DT, self.filter.cycle.params.offset) for o in scripted]
        return states, min(gaps) if gaps else math.inf


def twist(vx=0.0, vy=0.0, vz=0.0, wz=0.0) -> Twist:
    return ros_common.command_to_twist(VelocityCommand(vx, vy, vz, wz))


def odometry(robot: SimpleRobot, t: float) -> Odometry:
    msg = Odometry()
    msg.header.stamp = ros_common.to_time_msg(t)
    msg.header.frame_id, msg.child_frame_id = "odom", "base_link"
    b = robot.base_state(t)
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = b.position.tolist()
    q.x, q.y, q.z, q.w = b.orientation.tolist()
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    v.x, v.y, v.z = b.linear_velocity.tolist()
    w.z = float(b.angular_velocity[2])
    return msg


def obstacle_msg(o: ScriptedObstacle, t: float) -> Obstacle:
    s = o.at(t)
    m = Obstacle()
    m.id, m.plane = s.id, s.plane
    m.center.x, m.center.y, m.center.z = s.center.tolist()
    m.velocity.x, m.velocity.y, m.velocity.z = s.velocity.tolist()
    m.semi_axis_a, m.semi_axis_b = s.semi_axes.tolist()
    m.extent = s.extent
    m.velocity_source = Obstacle.VELOCITY_ESTIMATED
    return m


@pytest.fixture
def driver(ros_executor, request):
    params = getattr(request, "param", {})
    return Driver(ros_executor, **params)


PILLAR = ScriptedObstacle("pillar", np.array([2.0, 0.05, 0.5]))
# The simple robot lags its command (tau = 0.1 s): the body point may fall this far into the
# inflation margin that the filter keeps it out of.
LAG_TOLERANCE = 0.01


def vertical_clearance_needed(params) -> float:
    """Least distance (m) from the body point to a pillar's surface the filter keeps: the
    inflation of ``obstacle_input``: half the robot width plus the safety margin (the
    tie-break moves the circle as far as it grows it, so it adds nothing on the passing side)."""
    return 0.5 * params.robot_width + params.safety_margin - LAG_TOLERANCE


def horizontal_clearance_needed(params) -> float:
    """The same for a bar, in x-z: half the robot height plus the safety margin."""
    return 0.5 * params.robot_height + params.safety_margin - LAG_TOLERANCE


def test_static_obstacle_steers_or_brakes_and_h_stays_non_negative(driver):
    robot = SimpleRobot()
    states, gap = driver.run(robot, [PILLAR], VelocityCommand(0.5), 8.0)
    assert S.ACTIVE in {s.status for s in states}
    h = [s.min_h for s in states if s.h]
    assert min(h) >= -1e-3
    assert gap > vertical_clearance_needed(driver.filter.cycle.params)
    lat = np.array(driver.filter.latencies)
    print(f"odometry -> /cmd_vel_safe latency median {1e3 * np.median(lat):.3f} ms")


def test_moving_obstacle_on_a_collision_course_is_avoided(driver):
    mover = ScriptedObstacle("mover", np.array([4.0, 0.0, 0.5]), np.array([-0.4, 0.0, 0.0]))
    states, gap = driver.run(SimpleRobot(), [mover], VelocityCommand(0.5), 8.0)
    assert S.ACTIVE in {s.status for s in states}
    assert gap > vertical_clearance_needed(driver.filter.cycle.params)


def test_bar_ahead_gives_negative_vertical_speed(driver):
    bar = ScriptedObstacle("bar", np.array([1.8, 0.0, 0.42]), semi_axes=(0.05, 0.05), plane=1,
                           extent=3.0)
    robot = SimpleRobot()
    states, gap = driver.run(robot, [bar], VelocityCommand(0.4), 7.0)
    assert min(s.filtered.linear.z for s in states) < -0.02
    assert gap > horizontal_clearance_needed(driver.filter.cycle.params)
    assert robot.x > 2.0


def test_stale_odometry_brakes_to_zero(driver):
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.5), 2.0)
    t0 = 2.0
    for k in range(1, 60):  # clock and other inputs go on; odometry stops
        t = t0 + k * DT
        driver.publish(t, robot, [], twist(0.5), odom=False)
        spin_until(driver.executor, lambda: False, timeout=0.01)
    stale = [s for s in driver.states if s.status == S.STALE_INPUT]
    assert stale, "no STALE_INPUT after odometry stopped"
    assert "odometry" in stale[-1].status_text
    assert spin_until(driver.executor, lambda: driver.commands[-1].linear.x == 0.0, timeout=5)


def test_stale_obstacles_brake_to_zero_at_the_brake_deceleration(driver):
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.5), 1.0)
    params = driver.filter.cycle.params
    states = [driver.states[-1]]
    for k in range(1, 60):  # odometry and the reference go on: one cycle per step
        t = 1.0 + k * DT
        states.append(driver.step(t, robot, [], twist(0.5), obstacles_stamp=0.2))
    stale = [s.status == S.STALE_INPUT for s in states]
    # Lists stamped 0.2 s are rejected on arrival (older than the timeout), so the last good
    # list (stamped 1.0 s) goes stale once obstacles_timeout has passed (+1 cycle: two topics).
    first = stale.index(True)
    assert abs(first - params.obstacles_timeout / DT) <= 1.5 and all(stale[first:]), stale
    assert driver.filter.rejected["obstacles_stale_stamp"] >= 30
    assert all("obstacles" in s.status_text for s in states[first:])
    speeds = [s.filtered.linear.x for s in states[first - 1:]]
    assert speeds[0] > 0.3, "did not reach speed before the obstacles went stale"
    step = params.brake_decel * DT
    for before, after in zip(speeds, speeds[1:], strict=False):
        assert after == pytest.approx(max(before - step, 0.0), abs=1e-9), speeds
    assert speeds[-1] == 0.0


def test_stale_reference_becomes_zero(driver):
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.5), 1.0)
    state = None
    for k in range(1, 150):
        t = 1.0 + k * DT
        state = driver.step(t, robot, [], None)
        robot.step(ros_common.twist_to_command(state.filtered), DT)
    assert state.reference_stale
    assert state.reference.linear.x == 0.0
    assert abs(state.filtered.linear.x) < 0.05


def test_nan_messages_are_dropped_and_counted(driver):
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.3), 0.5)
    before = driver.states[-1].dropped_messages
    t = 0.5 + DT
    driver.publish(t, robot, None, twist(float("nan")), odom=False)
    bad_odom = odometry(robot, t)
    bad_odom.pose.pose.position.x = float("inf")
    driver.odom_pub.publish(bad_odom)
    bad_obs = obstacle_msg(PILLAR, t)
    bad_obs.center.y = float("nan")
    arr = ObstacleArray(obstacles=[bad_obs])
    arr.header.stamp = ros_common.to_time_msg(t)
    driver.obs_pub.publish(arr)
    # /cmd_vel and /odom are checked on arrival; /obstacles on arrival too unless a list was
    # decoded since the last cycle, then when the next cycle decodes it (so the next step
    # sends no newer obstacle list).
    assert spin_until(
        driver.executor,
        lambda: sum(driver.filter.dropped.values()) >= 2
        and (driver.filter.dropped["obstacles"] or driver.filter._obstacles_raw),
        10.0,
    )
    state = driver.step(t + DT, robot, None, twist(0.3))
    assert state.dropped_messages >= before + 3
    assert driver.filter.dropped == {"cmd_vel": 1, "odom": 1, "obstacles": 1}
    assert all(math.isfinite(c.linear.x) for c in driver.commands)


def test_inside_an_obstacle_is_an_emergency(driver):
    robot = SimpleRobot()
    inside = ScriptedObstacle("here", np.array([0.3, 0.0, 0.5]), semi_axes=(0.25, 0.25))
    states, _ = driver.run(robot, [inside], VelocityCommand(0.5), 0.5)
    assert states[-1].status == S.EMERGENCY_BRAKE
    assert states[-1].filtered.linear.x < 0.0


@pytest.mark.parametrize(
    "driver",
    [{"max_accel": 0.05, "max_yaw_accel": 0.05, "max_vertical_accel": 0.05, "windup_band": 10.0}],
    indirect=True,
)
def test_infeasible_qp_is_relaxed_and_flagged(driver):
    robot = SimpleRobot(vx=0.8)
    wall = ScriptedObstacle("wall", np.array([1.3, 0.0, 0.5]), semi_axes=(0.3, 0.3))
    for k in range(1, 4):
        t = k * DT
        state = driver.step(t, robot, [obstacle_msg(wall, t)], twist(0.8))
    assert state.status == S.RELAXED
    assert max(state.slack) > 0
    assert driver.filter.last_status_name() == "RELAXED"  # what the latency benchmark reads


def test_pass_through_when_disabled_at_run_time(driver):
    robot = SimpleRobot()
    result = driver.filter.set_parameters([Parameter("enabled", value=False)])
    assert result[0].successful
    state = driver.step(DT, robot, [obstacle_msg(PILLAR, DT)], twist(0.7, 0.0, 0.0, 0.2))
    assert state.status == S.PASS_THROUGH
    assert state.filtered == twist(0.7, 0.0, 0.0, 0.2)
    assert spin_until(
        driver.executor,
        lambda: any(
            st.message.startswith("filter disabled")
            for d in driver.diagnostics for st in d.status if st.name == "safety_filter"
        ),
        timeout=5.0,
    )


@pytest.mark.parametrize(
    "name, value, fragment",
    [("gamma", -1.0, "gamma"), ("model", "tank", "model"), ("rate", 0.0, "rate"),
     ("max_height", 0.1, "min_height")],
)
def test_invalid_parameters_are_rejected_with_the_reason(driver, name, value, fragment):
    result = driver.filter.set_parameters([Parameter(name, value=value)])[0]
    assert not result.successful
    assert fragment in result.reason
    assert getattr(driver.filter.cycle.params, name) != value


def test_invalid_start_up_parameters_raise(ros_executor):
    with pytest.raises(ValueError, match="gamma"):
        SafetyFilterNode(
            context=ros_executor.context_for_nodes,
            parameter_overrides=[Parameter("gamma", value=-2.0)],
        )


def test_obstacles_are_decoded_on_arrival_not_on_the_odometry_path(driver):
    """A list that arrives between cycles is decoded then; a second one waits for the cycle."""
    robot = SimpleRobot()
    driver.run(robot, [], VelocityCommand(0.3), 0.2)
    t = 0.2 + DT
    driver.step(t, robot, None, twist(0.3))  # a cycle after the last list (whatever its order)
    t += DT
    first = obstacle_msg(ScriptedObstacle("first", np.array([2.0, 0.0, 0.5])), t)
    driver.publish(t, robot, [first], None, odom=False)
    assert spin_until(driver.executor, lambda: driver.filter._obstacles is not None
                      and list(driver.filter._obstacles.ids) == ["first"], 5.0)
    second = obstacle_msg(ScriptedObstacle("second", np.array([2.0, 0.5, 0.5])), t)
    driver.publish(t, robot, [second], None, odom=False)
    assert spin_until(driver.executor, lambda: driver.filter._obstacles_raw is not None, 5.0)
    assert list(driver.filter._obstacles.ids) == ["first"]  # one decode between cycles
    state = driver.step(t, robot, None, twist(0.3))
    assert list(state.obstacle_ids) == ["second"]  # the cycle decoded the newest
