"""Reference planner node: /odom + /goal_pose -> /cmd_vel (the nominal, obstacle-blind command).

At ``rate`` Hz (sim time) it runs :class:`~safe_legged_c3bf.planning.ReferencePlanner` on the
newest odometry and publishes a base_link Twist: linear.x/y, linear.z = vertical body speed
holding ``z_nominal``, angular.z. With no odometry yet, or odometry older than
``odom_timeout`` (sim time), it publishes an all-zero Twist. It never looks at obstacles: the
C3BF safety filter downstream does.

Where the goal comes from (the newest wins): the ``scenario`` (name or path, its goal and
planner section), the parameters ``goal_x``/``goal_y`` (and ``goal_yaw``; NaN = unset) at
start-up or when they are set, and /goal_pose (PoseStamped in odom; a goal with NaN/Inf, a
non-odom frame or a non-finite orientation is ignored with a warning and counted). A goal
orientation of all zeros means "any final heading".

Scenario (``scenario`` parameter, fixed at start-up; empty = none): its planner section
overrides the parameters: ``mode: constant_velocity`` with ``velocity: [vx, vy, vz,
yaw_rate]`` (the limits are raised to fit it), or ``mode: goal`` (``holonomic`` stays
holonomic) to the scenario goal unless ``goal_x``/``goal_y`` are set; ``speed`` sets
``max_vx``; the goal tolerance caps ``goal_tolerance``; other keys are parameter overrides.
The robot kind sets ``z_nominal`` unless the planner section gives it.

In constant_velocity mode a non-zero ``constant_vz`` replaces the height hold on linear.z.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.rotations import yaw_from_quaternion
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.parameters import NodeParameters, same_value
from safe_legged_c3bf.planning.params import GOAL_PARAMS, NOMINAL_HEIGHT, ReferencePlannerParams
from safe_legged_c3bf.planning.reference_planner import (
    PlannerMode,
    PlannerStatus,
    ReferencePlanner,
    RobotPose,
    VelocityCommand,
)


def scenario_parameters(name_or_path: str, values: dict[str, object]) -> dict[str, object]:
    """Parameter values after applying a scenario to ``values`` (see the module docstring).

    Raises ValueError (a ScenarioError) for a missing or invalid scenario or an unknown
    planner parameter in it.
    """
    from safe_legged_c3bf.sim.scenario import load_scenario

    sc = load_scenario(name_or_path)
    out = dict(values)
    planner = sc.planner
    unknown = sorted(set(planner.params) - set(out))
    if unknown:
        raise ValueError(f"scenario {sc.name}: unknown planner parameter(s) {unknown}")
    if "z_nominal" not in planner.params and sc.robot.kind in NOMINAL_HEIGHT:
        out["z_nominal"] = NOMINAL_HEIGHT[sc.robot.kind]
    if planner.speed is not None:
        out["max_vx"] = float(planner.speed)
    if planner.mode == PlannerMode.CONSTANT_VELOCITY.value:
        vx, vy, vz, wz = (float(v) for v in planner.velocity)
        out["mode"] = PlannerMode.CONSTANT_VELOCITY.value
        out.update(constant_vx=vx, constant_vy=vy, constant_vz=vz, constant_yaw_rate=wz)
        # The limits only bound the goal modes: let the scripted velocity through.
        out["max_vx"] = max(float(out["max_vx"]), vx)
        out["max_vx_backward"] = max(float(out["max_vx_backward"]), -vx)
        out["max_vy"] = max(float(out["max_vy"]), abs(vy))
        out["max_vz"] = max(float(out["max_vz"]), abs(vz))
        out["max_yaw_rate"] = max(float(out["max_yaw_rate"]), abs(wz))
    else:
        if out["mode"] != PlannerMode.HOLONOMIC.value:
            out["mode"] = PlannerMode.GOAL.value
        if not (math.isfinite(float(out["goal_x"])) and math.isfinite(float(out["goal_y"]))):
            out["goal_x"], out["goal_y"] = (float(c) for c in sc.goal.position)
        out["goal_tolerance"] = min(float(out["goal_tolerance"]), float(sc.goal.tolerance))
    out.update(planner.params)
    return out


def goal_from_pose(msg: PoseStamped) -> tuple[tuple[float, float, float | None] | None, str]:
    """``((x, y, yaw or None), '')`` from a goal message, or ``(None, reason)`` if malformed."""
    frame = msg.header.frame_id
    if frame != topics.ODOM_FRAME:
        return None, f"goal frame '{frame}' is not '{topics.ODOM_FRAME}'"
    p, q = msg.pose.position, msg.pose.orientation
    if not (math.isfinite(p.x) and math.isfinite(p.y)):
        return None, f"goal position is not finite ({p.x}, {p.y})"
    quat = (q.x, q.y, q.z, q.w)
    if not all(math.isfinite(c) for c in quat):
        return None, "goal orientation is not finite"
    if math.sqrt(sum(c * c for c in quat)) < 1e-9:
        return (p.x, p.y, None), ""
    return (p.x, p.y, yaw_from_quaternion(*quat)), ""


class ReferencePlannerNode(Node):
    """Thin rclpy wrapper around the reference planner."""

    def __init__(self, **kwargs) -> None:
        """Create the node; ``kwargs`` go to rclpy's Node (context, parameter_overrides...)."""
        super().__init__("reference_planner", **kwargs)
        ros_common.use_sim_time(self)
        # A bad start-up value raises here (an integer is taken for a float); the scenario's
        # changes are applied first and shown as the parameters' values.
        self.params = NodeParameters(
            self, ReferencePlannerParams, apply=self._apply_params, prepare=self._with_scenario
        )
        p = self.params.value
        self.planner = ReferencePlanner(p.planner_config())
        self._set_goal_from_parameters(p, log=True)

        self._odom: Odometry | None = None
        self._pose: RobotPose | None = None
        self._odom_time: float | None = None
        self.dropped_odom = 0
        self.rejected_goals = 0
        self.accepted_goals = 0
        self.cycles = 0
        self._state = "no_odometry"
        self._last_state: str | None = None
        self._last_command = VelocityCommand()

        self._pub = ros_common.publisher(self, topics.CMD_VEL)
        self._diag_pub = ros_common.publisher(self, topics.DIAGNOSTICS)
        ros_common.subscription(self, topics.ODOM, self._on_odom)
        ros_common.subscription(self, topics.GOAL_POSE, self._on_goal)
        self._timer = self.create_timer(1.0 / float(p.rate), self._on_timer)
        self.create_timer(float(p.diagnostics_period), self._publish_diagnostics)
        self.get_logger().info(f"reference planner in {self.planner.config.mode.value} mode")

    # -- parameters ---------------------------------------------------------------------------
    def _with_scenario(self, values: dict[str, object]) -> dict[str, object]:
        """The start-up values with the ``scenario``'s applied (see the module docstring)."""
        if not values["scenario"]:
            return values
        applied = scenario_parameters(str(values["scenario"]), values)
        changed = [n for n, v in applied.items() if not same_value(v, values[n])]
        if changed:
            self.get_logger().info(
                f"scenario {values['scenario']}: " + ", ".join(f"{n}={applied[n]}" for n in changed)
            )
        return applied

    def _set_goal_from_parameters(self, p: ReferencePlannerParams, log: bool = False) -> None:
        """Set the goal of ``goal_x``/``goal_y``/``goal_yaw`` if x and y are given."""
        gx, gy, gyaw = (float(getattr(p, n)) for n in GOAL_PARAMS)
        if not (math.isfinite(gx) and math.isfinite(gy)):
            return
        accepted, reason = self.planner.set_goal(gx, gy, None if math.isnan(gyaw) else gyaw)
        if accepted and log:
            self.get_logger().info(f"goal ({gx:.3f}, {gy:.3f}) from parameters")
        elif not accepted:
            self.get_logger().warn(f"goal parameters ignored: {reason}")

    def _apply_params(
        self, old: ReferencePlannerParams, new: ReferencePlannerParams, names: frozenset[str]
    ) -> None:
        """Use validated new parameters: a new planner (keeping the goal), goal, timer rate."""
        config = new.planner_config()
        if config != self.planner.config:
            goal = self.planner.goal
            self.planner = ReferencePlanner(config)
            if goal is not None:
                self.planner.set_goal(goal.x, goal.y, goal.yaw)
        if names & set(GOAL_PARAMS):
            self._set_goal_from_parameters(new, log=True)
        if new.rate != old.rate:
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / float(new.rate), self._on_timer)

    # -- inputs -----------------------------------------------------------------------------
    def _now(self) -> float:
        return ros_common.now_seconds(self)

    def _on_odom(self, msg: Odometry) -> None:
        frame = msg.header.frame_id
        if not ros_common.odometry_is_finite(msg) or frame not in ("", topics.ODOM_FRAME):
            self.dropped_odom += 1
            self.get_logger().warn(
                "dropped an /odom with NaN/Inf or a frame other than odom",
                throttle_duration_sec=1.0,
            )
            return
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        self._pose = RobotPose(p.x, p.y, yaw_from_quaternion(q.x, q.y, q.z, q.w), p.z)
        self._odom_time = ros_common.from_time_msg(msg.header.stamp)

    def _on_goal(self, msg: PoseStamped) -> None:
        goal, reason = goal_from_pose(msg)
        if goal is None:
            self.rejected_goals += 1
            self.get_logger().warn(f"/goal_pose ignored: {reason}")
            return
        accepted, reason = self.planner.set_goal(*goal)
        if not accepted:
            self.rejected_goals += 1
            self.get_logger().warn(f"/goal_pose ignored: {reason}")
            return
        self.accepted_goals += 1
        yaw = "any" if goal[2] is None else f"{goal[2]:.2f} rad"
        self.get_logger().info(f"new goal ({goal[0]:.3f}, {goal[1]:.3f}), yaw {yaw}")
        if self.planner.config.mode is PlannerMode.CONSTANT_VELOCITY:
            self.get_logger().warn("constant_velocity mode: the goal is kept but not used")

    # -- cycle ------------------------------------------------------------------------------
    def odometry_stale(self, t: float) -> bool:
        """True without odometry or when it is older than ``odom_timeout`` at time ``t``."""
        timeout = float(self.params.value.odom_timeout)
        return self._odom_time is None or t - self._odom_time > timeout

    def _on_timer(self) -> None:
        t = self._now()
        if self._pose is None:
            self._state = "no_odometry"
            cmd = VelocityCommand()
        elif self.odometry_stale(t):
            self._state = "odometry_stale"
            cmd = VelocityCommand()
        else:
            cmd = self.planner.compute(self._pose, t)
            vz = float(self.params.value.constant_vz)
            if self.planner.config.mode is PlannerMode.CONSTANT_VELOCITY and vz != 0.0:
                cmd = VelocityCommand(cmd.vx, cmd.vy, vz, cmd.yaw_rate)
            self._state = self.planner.status.value
        self._last_command = cmd
        self._pub.publish(ros_common.command_to_twist(cmd))
        self.cycles += 1
        if self._state != self._last_state:
            # One call site per severity: rclpy refuses to change it between calls.
            if self._state in ("no_odometry", "odometry_stale"):
                if self._last_state is not None:
                    self.get_logger().warn(f"planner status: {self._state}: commanding zero")
            else:
                self.get_logger().info(f"planner status: {self._state}")
            self._last_state = self._state
            self._publish_diagnostics()

    def distance_to_goal(self) -> float | None:
        """Planar distance (m) from the newest pose to the goal, None if either is missing."""
        goal, pose = self.planner.goal, self._pose
        if goal is None or pose is None:
            return None
        return math.hypot(goal.x - pose.x, goal.y - pose.y)

    def _publish_diagnostics(self) -> None:
        state = self._state
        if state in ("no_odometry", "odometry_stale", PlannerStatus.INVALID_POSE.value):
            level, text = "warn", f"{state}: commanding zero"
        elif state == PlannerStatus.IDLE.value:
            level, text = "ok", "no goal: holding still"
        else:
            level, text = "ok", state
        goal = self.planner.goal
        distance = self.distance_to_goal()
        cmd = self._last_command
        values = {
            "status": state,
            "mode": self.planner.config.mode.value,
            "goal": "none" if goal is None else f"{goal.x:.3f}, {goal.y:.3f}",
            "distance_to_goal": "n/a" if distance is None else f"{distance:.3f}",
            "arrived": self.planner.arrived,
            "command": f"{cmd.vx:.3f}, {cmd.vy:.3f}, {cmd.vz:.3f}, {cmd.yaw_rate:.3f}",
            "accepted_goals": self.accepted_goals,
            "rejected_goals": self.rejected_goals,
            "dropped_odom": self.dropped_odom,
            "cycles": self.cycles,
        }
        status = ros_common.diagnostic_status("reference_planner", level, text, values)
        self._diag_pub.publish(ros_common.diagnostic_array(self, [status]))


def main(args: list[str] | None = None) -> int:
    """Run the reference planner node as its own process."""
    return ros_common.run_node(ReferencePlannerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
