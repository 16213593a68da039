"""C3BF safety filter node: /cmd_vel + /odom + /obstacles -> /cmd_vel_safe.

Publishes /cmd_vel_safe at ``rate`` Hz (sim time), /c3bf/state every cycle and /diagnostics
once a second and on every status change. A cycle runs as soon as odometry arrives (at most
``rate`` times per second), so the command reacts to the newest state; a sim-time timer keeps
the cycles (and the braking) going when odometry stops. All logic is in
:class:`~safe_legged_c3bf.filtering.safety_cycle.SafetyFilterCycle`; this is the ROS wrapper.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, fields

import numpy as np
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node

from safe_legged_c3bf import topics
from safe_legged_c3bf.c3bf import InvalidInputError
from safe_legged_c3bf.filtering.obstacle_input import ObstacleSet
from safe_legged_c3bf.filtering.params import FilterParams
from safe_legged_c3bf.filtering.safety_cycle import CycleOutput, CycleStatus, SafetyFilterCycle
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf_msgs.msg import ObstacleArray, SafetyFilterState

_DESCRIPTIONS = {
    f.name: (f.name + ": see safe_legged_c3bf/filtering/params.py (SI units)")
    for f in fields(FilterParams)
}


def obstacles_from_msg(msg: ObstacleArray) -> ObstacleSet | None:
    """The message's obstacles, validated once; None if any has a non-finite/invalid value."""
    obs = msg.obstacles
    try:
        return ObstacleSet.from_arrays(
            [o.id for o in obs],
            [o.plane for o in obs],
            [(o.center.x, o.center.y, o.center.z) for o in obs],
            [(o.velocity.x, o.velocity.y, o.velocity.z) for o in obs],
            [(o.semi_axis_a, o.semi_axis_b) for o in obs],
            [o.extent for o in obs],
        )
    except InvalidInputError:
        return None


class SafetyFilterNode(Node):
    """Thin rclpy wrapper around the C3BF safety filter cycle."""

    def __init__(self, **kwargs) -> None:
        """Create the node; ``kwargs`` go to rclpy's Node (context, parameter_overrides...)."""
        super().__init__("safety_filter", **kwargs)
        ros_common.use_sim_time(self)
        defaults = asdict(FilterParams())
        for name, value in defaults.items():
            if isinstance(value, tuple):
                value = [float(x) for x in value]
            descriptor = ParameterDescriptor(description=_DESCRIPTIONS[name])
            self.declare_parameter(name, value, descriptor)
        values = {name: self.get_parameter(name).value for name in defaults}
        values["weights"] = tuple(float(w) for w in values["weights"])
        params = FilterParams(**values).validate()  # a bad start-up value raises here
        self.cycle = SafetyFilterCycle(params)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self._reference = None
        self._reference_time: float | None = None
        self._base = None
        self._obstacles: ObstacleSet | None = None  # validated once, on arrival
        self._obstacles_time: float | None = None
        self._last_cycle: float | None = None
        self._last_status: CycleStatus | None = None
        self.dropped = {"cmd_vel": 0, "odom": 0, "obstacles": 0}
        self.latencies: list[float] = []  # wall s from odometry receipt to publish
        self.cycles = 0

        self._cmd_pub = ros_common.publisher(self, topics.CMD_VEL_SAFE)
        self._cmd_msg = Twist()  # filled and published every cycle (publish serialises it)
        self._state_pub = ros_common.publisher(self, topics.FILTER_STATE)
        self._diag_pub = ros_common.publisher(self, topics.DIAGNOSTICS)
        ros_common.subscription(self, topics.CMD_VEL, self._on_reference)
        ros_common.subscription(self, topics.ODOM, self._on_odom)
        ros_common.subscription(self, topics.OBSTACLES, self._on_obstacles)
        self._timer = self.create_timer(1.0 / params.rate, self._on_timer)
        self.create_timer(1.0, self._publish_diagnostics)
        self._last_output: CycleOutput | None = None

    # -- parameters ---------------------------------------------------------------------------
    def _on_set_parameters(self, params) -> SetParametersResult:
        changes = {}
        for p in params:
            if p.name in FilterParams.__dataclass_fields__:
                changes[p.name] = tuple(p.value) if p.name == "weights" else p.value
        if not changes:
            return SetParametersResult(successful=True)
        try:
            new = self.cycle.params.updated(**changes)
        except (ValueError, TypeError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        rate_changed = new.rate != self.cycle.params.rate
        self.cycle.set_params(new)
        if rate_changed:
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / new.rate, self._on_timer)
        self.get_logger().info(f"parameters updated: {changes}")
        return SetParametersResult(successful=True)

    # -- inputs -----------------------------------------------------------------------------
    def _now(self) -> float:
        return ros_common.now_seconds(self)

    def _on_reference(self, msg: Twist) -> None:
        if not ros_common.twist_is_finite(msg):
            self.dropped["cmd_vel"] += 1
            self.get_logger().warn("dropped a /cmd_vel with NaN/Inf", throttle_duration_sec=1.0)
            return
        self._reference = ros_common.twist_to_command(msg)
        self._reference_time = self._now()

    def _on_obstacles(self, msg: ObstacleArray) -> None:
        obstacles = obstacles_from_msg(msg)
        stamp = ros_common.from_time_msg(msg.header.stamp)
        if obstacles is None or not math.isfinite(stamp):
            self.dropped["obstacles"] += 1
            self.get_logger().warn("dropped an /obstacles with NaN/Inf", throttle_duration_sec=1.0)
            return
        self._obstacles, self._obstacles_time = obstacles, stamp

    def _on_odom(self, msg: Odometry) -> None:
        received = time.perf_counter()
        if not ros_common.odometry_is_finite(msg):
            self.dropped["odom"] += 1
            self.get_logger().warn("dropped an /odom with NaN/Inf", throttle_duration_sec=1.0)
            return
        self._base = ros_common.odometry_to_base_state(msg)
        t = self._base.stamp
        period = 1.0 / self.cycle.params.rate
        if self._last_cycle is None or t - self._last_cycle >= period - 1e-6:
            self._run_cycle(t, received)

    def _on_timer(self) -> None:
        t = self._now()
        period = 1.0 / self.cycle.params.rate
        if self._last_cycle is None or t - self._last_cycle >= 1.5 * period:
            self._run_cycle(t)

    # -- cycle ------------------------------------------------------------------------------
    def _run_cycle(self, t: float, received: float | None = None) -> None:
        """Run one cycle; ``received`` is the wall time the triggering odometry arrived."""
        out = self.cycle.step(
            t, self._reference, self._reference_time, self._base, self._obstacles,
            self._obstacles_time,
        )
        self._cmd_pub.publish(ros_common.command_to_twist(out.command, self._cmd_msg))
        if received is not None:
            self.latencies.append(time.perf_counter() - received)
            if len(self.latencies) > 10000:
                del self.latencies[:5000]
        self._last_cycle = t
        self.cycles += 1
        self._state_pub.publish(self._state_msg(t, out))
        self._last_output = out
        if out.status != self._last_status:
            text = f"filter status {out.status.name}: {out.text}"
            if out.status >= CycleStatus.RELAXED:
                self.get_logger().warn(text)
            else:
                self.get_logger().info(text)
            self._last_status = out.status
            self._publish_diagnostics()

    def _state_msg(self, t: float, out: CycleOutput) -> SafetyFilterState:
        msg = SafetyFilterState()
        msg.header.stamp = ros_common.to_time_msg(t)
        msg.header.frame_id = topics.BASE_FRAME
        msg.status = int(out.status)
        msg.status_text = out.text
        msg.reference_stale = out.reference_stale
        msg.reference = ros_common.command_to_twist(out.reference)
        msg.filtered = ros_common.command_to_twist(out.command)
        msg.u_reference = [float(x) for x in out.u_reference]
        msg.u_safe = [float(x) for x in out.u_safe]
        msg.obstacle_ids = list(out.obstacle_ids)
        r = out.result
        if r is not None:
            msg.h = r.h.tolist()
            msg.constraint_value = r.constraint.tolist()
            msg.slack = r.slack.tolist()
            msg.constraint_active = [bool(a) for a in r.active]
            msg.min_h = float(r.h.min()) if r.h.size else math.inf
            msg.solver = r.solver
            msg.solve_time = float(r.solve_time)
        else:
            msg.min_h = math.inf
            msg.solver = "none"
        msg.dropped_messages = sum(self.dropped.values())
        return msg

    def _publish_diagnostics(self) -> None:
        out = self._last_output
        status = out.status if out is not None else CycleStatus.STALE_INPUT
        level = {
            CycleStatus.PASS_THROUGH: "warn",
            CycleStatus.INACTIVE: "ok",
            CycleStatus.ACTIVE: "ok",
            CycleStatus.RELAXED: "warn",
            CycleStatus.EMERGENCY_BRAKE: "error",
            CycleStatus.STALE_INPUT: "warn",
            CycleStatus.INVALID_INPUT: "error",
        }[status]
        lat = np.array(self.latencies[-1000:]) if self.latencies else np.zeros(1)
        values = {
            "status": status.name,
            "cycles": self.cycles,
            **{f"dropped_{k}": v for k, v in self.dropped.items()},
            "latency_median_ms": f"{1e3 * float(np.median(lat)):.3f}",
        }
        text = out.text if out is not None else "waiting for inputs"
        diag = ros_common.diagnostic_status("safety_filter", level, text, values)
        self._diag_pub.publish(ros_common.diagnostic_array(self, [diag]))


def main(args: list[str] | None = None) -> int:
    """Run the safety filter node as its own process."""
    return ros_common.run_node(SafetyFilterNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
