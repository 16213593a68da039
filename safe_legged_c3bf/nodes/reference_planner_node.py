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
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from safe_legged_c3bf import topics
from safe_legged_c3bf.node_parameters import (
    NOMINAL_HEIGHT,
    PLANNER_DEFAULTS,
    PLANNER_NODE_DEFAULTS,
)
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.planning.reference_planner import (
    PlannerConfig,
    PlannerMode,
    PlannerStatus,
    ReferencePlanner,
    RobotPose,
    VelocityCommand,
)
from safe_legged_c3bf.rotations import yaw_from_quaternion

# The parameter names and defaults live in a ROS-free module: scenario files are checked
# against them when they are loaded.
NODE_DEFAULTS = PLANNER_NODE_DEFAULTS
GOAL_PARAMS = ("goal_x", "goal_y", "goal_yaw")
CONSTANT_PARAMS = ("constant_vx", "constant_vy", "constant_vz", "constant_yaw_rate")

_DESCRIPTIONS = {
    "mode": "goal | holonomic | constant_velocity",
    "max_vx": "largest forward speed (m/s), > 0",
    "max_vx_backward": "largest backward speed, holonomic mode (m/s), >= 0",
    "max_vy": "largest lateral speed (m/s), > 0",
    "max_vz": "largest vertical speed of the height hold (m/s), > 0",
    "max_yaw_rate": "largest yaw rate (rad/s), > 0",
    "max_linear_accel": "rate limit of vx, vy, vz (m/s^2); 0 = none",
    "max_yaw_accel": "rate limit of the yaw rate (rad/s^2); 0 = none",
    "k_speed": "speed gain towards the goal (1/s); < k_heading and < 2 max_yaw_rate in goal mode",
    "k_heading": "heading gain towards the goal (1/s)",
    "k_yaw": "final-yaw gain (1/s)",
    "k_z": "height gain (1/s)",
    "z_nominal": "body height held through linear.z (m, odom z of base_link)",
    "hold_height": "false: linear.z is always 0",
    "goal_tolerance": "goal reached within this distance (m)",
    "resume_distance": "after arriving, move again beyond this distance (m), > goal_tolerance",
    "yaw_tolerance": "goal yaw reached within this error (rad)",
    "yaw_resume_tolerance": "after arriving, turn again beyond this error (rad)",
    "heading_slowdown_angle": "forward speed goes to 0 at this heading error (rad), <= pi/2",
    "rate": "publish rate of /cmd_vel (Hz, sim time), > 0",
    "odom_timeout": "odometry older than this (s, sim time) -> zero command, > 0",
    "diagnostics_period": "period of /diagnostics (s, sim time), > 0; fixed at start-up",
    "scenario": "scenario name or path whose goal/planner section to use; empty = none; "
    "fixed at start-up",
    "goal_x": "goal x in odom (m); NaN = none",
    "goal_y": "goal y in odom (m); NaN = none",
    "goal_yaw": "final heading at the goal (rad); NaN = any",
    "constant_vx": "constant_velocity mode: forward speed (m/s)",
    "constant_vy": "constant_velocity mode: lateral speed (m/s)",
    "constant_vz": "constant_velocity mode: vertical speed (m/s); 0 = hold z_nominal",
    "constant_yaw_rate": "constant_velocity mode: yaw rate (rad/s)",
}


def parameter_defaults() -> dict[str, object]:
    """Default value of every parameter (equal to config/reference_planner.yaml)."""
    return {**NODE_DEFAULTS, **PLANNER_DEFAULTS}


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def make_planner_config(values: dict[str, object]) -> PlannerConfig:
    """PlannerConfig from parameter values; raises ValueError naming the bad parameter."""
    for name, default in PLANNER_DEFAULTS.items():
        value = values[name]
        if _is_number(default) and not _is_number(value):
            raise ValueError(f"{name} must be a number, got {value!r}")
    for name in CONSTANT_PARAMS:
        value = values[name]
        if not _is_number(value) or not math.isfinite(float(value)):
            raise ValueError(f"{name} must be a finite number, got {value!r}")
    kwargs = {name: values[name] for name in PLANNER_DEFAULTS}
    for name in ("max_linear_accel", "max_yaw_accel"):  # 0 = no limit
        if kwargs[name] == 0:
            kwargs[name] = None
        elif _is_number(kwargs[name]) and kwargs[name] < 0:
            raise ValueError(f"{name} must be >= 0 (0 = no limit), got {kwargs[name]!r}")
    rate = values["rate"]
    kwargs["control_period"] = 1.0 / float(rate)
    kwargs["constant_velocity"] = (
        values["constant_vx"], values["constant_vy"], values["constant_yaw_rate"]
    )
    try:
        config = PlannerConfig(**kwargs)
    except TypeError as err:
        raise ValueError(str(err)) from None
    if abs(float(values["constant_vz"])) > config.max_vz:
        raise ValueError("constant_vz exceeds max_vz")
    return config


def check_node_parameter(name: str, value: object) -> str:
    """Reason why ``value`` is invalid for node parameter ``name`` ('' if it is fine)."""
    if name == "scenario":
        return "" if isinstance(value, str) else f"scenario must be a string, got {value!r}"
    if not _is_number(value):
        return f"{name} must be a number, got {value!r}"
    if name in GOAL_PARAMS:
        return "" if not math.isinf(float(value)) else f"{name} must be finite or NaN"
    if name in CONSTANT_PARAMS:
        return "" if math.isfinite(float(value)) else f"{name} must be finite"
    if not math.isfinite(float(value)) or not value > 0:
        return f"{name} must be a finite number > 0, got {value!r}"
    return ""


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
        defaults = parameter_defaults()
        for name, default in defaults.items():
            descriptor = ParameterDescriptor(
                description=_DESCRIPTIONS[name], dynamic_typing=_is_number(default)
            )
            self.declare_parameter(name, default, descriptor)
        values = {name: self.get_parameter(name).value for name in defaults}
        for name in NODE_DEFAULTS:
            reason = check_node_parameter(name, values[name])
            if reason:
                raise ValueError(reason)
        if values["scenario"]:
            applied = scenario_parameters(str(values["scenario"]), values)
            changed = [
                Parameter(name, value=value) for name, value in applied.items()
                if value != values[name] and not (
                    _is_number(value) and math.isnan(value) and math.isnan(values[name])
                )
            ]
            values = applied
            if changed:
                self.set_parameters(changed)  # no callback yet: validated below
                self.get_logger().info(
                    f"scenario {values['scenario']}: "
                    + ", ".join(f"{p.name}={p.value}" for p in changed)
                )
        self._values = values
        self.planner = ReferencePlanner(make_planner_config(values))  # bad values raise here
        self._set_goal_from_parameters(values, log=True)
        self.add_on_set_parameters_callback(self._on_set_parameters)

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
        self._timer = self.create_timer(1.0 / float(values["rate"]), self._on_timer)
        self.create_timer(float(values["diagnostics_period"]), self._publish_diagnostics)
        self.get_logger().info(f"reference planner in {self.planner.config.mode.value} mode")

    # -- parameters ---------------------------------------------------------------------------
    def _set_goal_from_parameters(self, values: dict[str, object], log: bool = False) -> None:
        gx, gy, gyaw = (float(values[n]) for n in GOAL_PARAMS)
        if not (math.isfinite(gx) and math.isfinite(gy)):
            return
        accepted, reason = self.planner.set_goal(gx, gy, None if math.isnan(gyaw) else gyaw)
        if accepted and log:
            self.get_logger().info(f"goal ({gx:.3f}, {gy:.3f}) from parameters")
        elif not accepted:
            self.get_logger().warn(f"goal parameters ignored: {reason}")

    def _on_set_parameters(self, params) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in self._values}
        if not changes:
            return SetParametersResult(successful=True)
        for name, value in changes.items():
            if name == "scenario" and value != self._values["scenario"]:
                return SetParametersResult(
                    successful=False, reason="scenario is fixed at start-up"
                )
            if name == "diagnostics_period" and value != self._values[name]:
                return SetParametersResult(
                    successful=False, reason="diagnostics_period is fixed at start-up"
                )
            if name in NODE_DEFAULTS:
                reason = check_node_parameter(name, value)
                if reason:
                    return SetParametersResult(successful=False, reason=reason)
        values = {**self._values, **changes}
        try:
            config = make_planner_config(values)
        except ValueError as err:
            return SetParametersResult(successful=False, reason=str(err))
        if config != self.planner.config:
            goal = self.planner.goal
            self.planner = ReferencePlanner(config)
            if goal is not None:
                self.planner.set_goal(goal.x, goal.y, goal.yaw)
        if any(name in GOAL_PARAMS for name in changes):
            self._set_goal_from_parameters(values, log=True)
        if values["rate"] != self._values["rate"]:
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / float(values["rate"]), self._on_timer)
        self._values = values
        self.get_logger().info(f"parameters updated: {changes}")
        return SetParametersResult(successful=True)

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
        return self._odom_time is None or t - self._odom_time > float(self._values["odom_timeout"])

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
            vz = float(self._values["constant_vz"])
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
