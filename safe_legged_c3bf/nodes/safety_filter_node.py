"""C3BF safety filter node: /cmd_vel + /odom + /obstacles -> /cmd_vel_safe.

Publishes /cmd_vel_safe at ``rate`` Hz (sim time), /c3bf/state every cycle and /diagnostics
once a second and on every status change. A cycle runs as soon as odometry arrives (at most
``rate`` times per second), so the command reacts to the newest state; a sim-time timer keeps
the cycles (and the braking) going when odometry stops. All logic is in
:class:`~safe_legged_c3bf.safety.safety_cycle.SafetyFilterCycle`; this is the ROS wrapper.

Untrusted inputs: every cycle runs at the node's own clock, never at a message's stamp.
/odom and /obstacles stamped more than ``max_future_stamp`` ahead of that clock, or older
than their timeout, are rejected and counted (``/diagnostics``: ``rejected_<topic>_<why>``);
so are NaN/Inf messages, /obstacles larger than ``max_message_bytes`` (before decoding) and
both topics while they have more than one publisher (which one to believe cannot be told).
An /obstacles message is decoded on arrival, off the odometry-to-command path, unless one
was decoded since the last cycle: then it waits, superseded by any newer one, and the cycle
decodes the newest (a flood costs at most two decodes per cycle). The decoded list keeps its
``max_obstacles`` obstacles nearest the robot.
"""

from __future__ import annotations

import math
import time
from collections import Counter

import numpy as np
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.serialization import deserialize_message

from safe_legged_c3bf.c3bf import InvalidInputError
from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.parameters import NodeParameters
from safe_legged_c3bf.safety import StampGate, StampVerdict, cap_nearest
from safe_legged_c3bf.safety.obstacle_input import ObstacleSet
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import CycleOutput, CycleStatus, SafetyFilterCycle
from safe_legged_c3bf_msgs.msg import ObstacleArray, SafetyFilterState


def obstacles_from_msg(
    msg: ObstacleArray, robot_xy: tuple[float, float] | None = None, limit: int | None = None
) -> ObstacleSet | None:
    """The message's obstacles, validated once; None if any has a non-finite/invalid value.

    With ``limit``, only the ``limit`` obstacles nearest ``robot_xy`` (odom, m) are kept.
    """
    obs = msg.obstacles
    if limit is not None and len(obs) > limit:
        centers = np.array([(o.center.x, o.center.y) for o in obs], dtype=float)
        obs = [obs[i] for i in cap_nearest(centers, robot_xy, limit).tolist()]
    try:
        return ObstacleSet.from_arrays(
            [o.id for o in obs],
            [o.plane for o in obs],
            [(o.center.x, o.center.y, o.center.z) for o in obs],
            [(o.velocity.x, o.velocity.y, o.velocity.z) for o in obs],
            [(o.semi_axis_a, o.semi_axis_b) for o in obs],
            [o.extent for o in obs],
            [o.orientation for o in obs],
        )
    except InvalidInputError:
        return None


class SafetyFilterNode(Node):
    """Thin rclpy wrapper around the C3BF safety filter cycle."""

    def __init__(self, **kwargs) -> None:
        """Create the node; ``kwargs`` go to rclpy's Node (context, parameter_overrides...)."""
        super().__init__("safety_filter", **kwargs)
        ros_common.use_sim_time(self)
        # A bad start-up value raises here; every parameter can be changed live.
        self.params = NodeParameters(self, FilterParams, apply=self._apply_params)
        params = self.params.value
        self.cycle = SafetyFilterCycle(params)

        self._reference = None
        self._reference_time: float | None = None
        self._base = None
        self._obstacles: ObstacleSet | None = None  # validated once, on arrival
        self._obstacles_time: float | None = None
        self._last_cycle: float | None = None
        self._last_status: CycleStatus | None = None
        self._obstacles_raw: bytes | None = None  # latest /obstacles not decoded yet
        self._decoded_this_cycle = False  # an /obstacles list was decoded since the last cycle
        self.dropped = {"cmd_vel": 0, "odom": 0, "obstacles": 0}
        self.rejected: Counter[str] = Counter()  # "<topic>_<reason>" -> count
        self._gates = self._make_gates(params)
        self.latencies: list[float] = []  # wall s from odometry receipt to publish
        self.cycles = 0

        self._cmd_pub = ros_common.publisher(self, topics.CMD_VEL_SAFE)
        self._cmd_msg = Twist()  # filled and published every cycle (publish serialises it)
        self._state_pub = ros_common.publisher(self, topics.FILTER_STATE)
        self._diag_pub = ros_common.publisher(self, topics.DIAGNOSTICS)
        ros_common.subscription(self, topics.CMD_VEL, self._on_reference)
        ros_common.subscription(self, topics.ODOM, self._on_odom)
        ros_common.subscription(self, topics.OBSTACLES, self._on_obstacles, raw=True)
        self._single = {
            "odom": ros_common.SinglePublisher(self, topics.ODOM),
            "obstacles": ros_common.SinglePublisher(self, topics.OBSTACLES),
        }
        self._timer = self.create_timer(1.0 / params.rate, self._on_timer)
        self.create_timer(1.0, self._publish_diagnostics)
        self._last_output: CycleOutput | None = None

    def last_status_name(self) -> str:
        """Status of the last cycle (``CycleStatus`` name), "" before the first."""
        return "" if self._last_output is None else self._last_output.status.name

    # -- parameters ---------------------------------------------------------------------------
    def _apply_params(self, old: FilterParams, new: FilterParams, names: frozenset[str]) -> None:
        """Use validated new parameters: the cycle's, the stamp gates and the timer's rate."""
        self.cycle.set_params(new)
        self._gates = self._make_gates(new)
        if new.rate != old.rate:
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / new.rate, self._on_timer)

    # -- inputs -----------------------------------------------------------------------------
    @staticmethod
    def _make_gates(params: FilterParams) -> dict[str, StampGate]:
        return {
            "odom": StampGate(params.max_future_stamp, params.odom_timeout),
            "obstacles": StampGate(params.max_future_stamp, params.obstacles_timeout),
        }

    def _now(self) -> float:
        return ros_common.now_seconds(self)

    def _reject(self, topic: str, reason: str) -> None:
        """Count a rejected message and say so (throttled)."""
        self.rejected[f"{topic}_{reason}"] += 1
        if reason in ("non_finite", "invalid"):
            self.dropped[topic] += 1
        self.get_logger().warn(
            f"rejected an /{topic} message: {reason}", throttle_duration_sec=1.0
        )

    def _accept(self, topic: str, stamp: float, now: float) -> bool:
        """Stamp and publisher checks of an /odom or /obstacles message (counted if not)."""
        if not self._single[topic].ok():
            self._reject(topic, "second_publisher")
            return False
        verdict = self._gates[topic].check(stamp, now)
        if verdict is not StampVerdict.OK:
            self._reject(topic, verdict.value)
            return False
        return True

    def _on_reference(self, msg: Twist) -> None:
        if not ros_common.twist_is_finite(msg):
            self._reject("cmd_vel", "non_finite")
            return
        self._reference = ros_common.twist_to_command(msg)
        self._reference_time = self._now()

    def _on_obstacles(self, raw: bytes) -> None:
        """Decode the list now unless one was decoded this cycle (then keep its bytes)."""
        if len(raw) > self.cycle.params.max_message_bytes:
            self._reject("obstacles", "too_large")
            return
        self._obstacles_raw = raw
        if not self._decoded_this_cycle:
            self._decode_obstacles(self._now())

    def _decode_obstacles(self, now: float) -> None:
        """Decode, check and keep the latest /obstacles message, if a new one came."""
        raw, self._obstacles_raw = self._obstacles_raw, None
        if raw is None:
            return
        self._decoded_this_cycle = True
        msg = deserialize_message(raw, ObstacleArray)
        stamp = ros_common.from_time_msg(msg.header.stamp)
        if not self._accept("obstacles", stamp, now):
            return
        limit = self.cycle.params.max_obstacles
        if len(msg.obstacles) > limit:
            self.rejected["obstacles_over_max_obstacles"] += len(msg.obstacles) - limit
        base = self._base
        robot_xy = None if base is None else (float(base.position[0]), float(base.position[1]))
        obstacles = obstacles_from_msg(msg, robot_xy, limit)
        if obstacles is None:
            self._reject("obstacles", "invalid")
            return
        self._obstacles, self._obstacles_time = obstacles, stamp

    def _on_odom(self, msg: Odometry) -> None:
        received = time.perf_counter()
        if not ros_common.odometry_is_finite(msg):
            self._reject("odom", "non_finite")
            return
        t = self._now()
        if not self._accept("odom", ros_common.from_time_msg(msg.header.stamp), t):
            return
        self._base = ros_common.odometry_to_base_state(msg)
        period = 1.0 / self.cycle.params.rate
        last = self._last_cycle
        if last is None or t - last >= period - 1e-6 or t < last:
            self._run_cycle(t, received)

    def _on_timer(self) -> None:
        t = self._now()
        period = 1.0 / self.cycle.params.rate
        last = self._last_cycle
        if last is None or t - last >= 1.5 * period or t < last:  # t < last: clock went back
            self._run_cycle(t)

    # -- cycle ------------------------------------------------------------------------------
    def _run_cycle(self, t: float, received: float | None = None) -> None:
        """Run one cycle; ``received`` is the wall time the triggering odometry arrived."""
        self._decode_obstacles(t)  # the newest list, if one waited (see the module docstring)
        self._decoded_this_cycle = False
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
        msg.dropped_messages = sum(self.rejected.values())
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
            "rejected_total": sum(self.rejected.values()),
            **{f"rejected_{k}": v for k, v in sorted(self.rejected.items())},
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
