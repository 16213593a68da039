"""Gait controller node: /cmd_vel_safe + /odom + /joint_states -> /joint_commands.

Hosts any :class:`~safe_legged_c3bf.interfaces.gait_controller.GaitController` (the A1 convex-
MPC trot or the biped ZMP walk, chosen by the ``robot`` parameter). As on a real robot, it runs
on the high-rate sensors: it ticks when /imu and /joint_states of one stamp have both arrived
and at least ``control_period`` has passed since the last tick. The base state combines the IMU
(orientation, angular velocity) with the latest /odom (position and velocity, which arrive at a
navigation rate), its position extrapolated to the tick. Each MotorCommand is stamped with the
state it was computed from. No /cmd_vel_safe for ``command_timeout`` seconds (sim time) -> the
command becomes zero and the robot stops and stands. A state published again with the same
stamp (the simulator waiting for a command) is answered again with the same command.

Untrusted inputs: /imu, /joint_states and /odom stamped more than ``max_future_stamp`` ahead of
the node's clock, or older than ``command_timeout`` behind it, are rejected and counted (a
publisher that is not on sim time cannot stall the controller by moving its time ahead). While
/cmd_vel_safe has more than one publisher the command is ambiguous (which one is the safety
filter cannot be told): every command is rejected and the robot stops and stands.
"""

from __future__ import annotations

import math
import time
from collections import Counter

import numpy as np
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState

from safe_legged_c3bf.gait.factory import make_gait_controller
from safe_legged_c3bf.gait.params import GaitControllerParams
from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.nodes.parameters import NodeParameters
from safe_legged_c3bf.safety import StampGate, StampVerdict
from safe_legged_c3bf_msgs.msg import MotorCommand

_SLOW_TICK = 0.02  # wall s: a tick slower than this is logged (the drivers time out at 0.1 s)
_STATE_GAP = 0.05  # wall s between two states beyond which the gap is logged


class GaitControllerNode(Node):
    """Thin rclpy wrapper around a gait controller."""

    def __init__(self, **kwargs) -> None:
        """Create the node; ``kwargs`` go to rclpy's Node (context, parameter_overrides...)."""
        super().__init__("gait_controller", **kwargs)
        ros_common.use_sim_time(self)
        # A bad start-up value raises here; robot and controller_config are fixed.
        self.params = NodeParameters(self, GaitControllerParams, apply=self._apply_params)
        p = self.params.value
        self._timeout = float(p.command_timeout)
        self._gate = StampGate(float(p.max_future_stamp), self._timeout)
        self.rejected: Counter[str] = Counter()  # "<topic>_<reason>" -> count
        robot = p.robot
        self.controller = make_gait_controller(robot, p.controller_config or None)

        self._names_index: np.ndarray | None = None
        self._names_key: tuple[str, ...] = ()
        self._odom: BaseState | None = None
        self._imu: Imu | None = None
        self._joints: JointState | None = None
        self._last_tick: float | None = None
        self._last_processed_stamp = -math.inf
        self._last_msg: MotorCommand | None = None
        self._answered: tuple[Imu, JointState] | None = None  # the state _last_msg answers
        self._command = VelocityCommand()
        self._command_time: float | None = None
        self._dropped = 0
        self._ticks = 0
        self._tick_wall = 0.0
        self._tick_max = 0.0  # wall s of the slowest tick
        self._last_imu_wall: float | None = None  # wall s of the last accepted /imu
        self._last_imu_t = 0.0  # its stamp (sim s)
        self._command_stale = True
        self._start_subscribers = int(p.start_subscribers)
        self._start_wait = float(p.start_wait)
        self._start_deadline: float | None = None  # wall s, set by the first state
        self._start_held = True  # until the readers are there or start_wait has passed

        self._pub = ros_common.publisher(self, topics.JOINT_COMMANDS)
        self._diag_pub = ros_common.publisher(self, topics.DIAGNOSTICS)
        ros_common.subscription(self, topics.ODOM, self._on_odom)
        ros_common.subscription(self, topics.JOINT_STATES, self._on_joints)
        ros_common.subscription(self, topics.IMU, self._on_imu)
        ros_common.subscription(self, topics.CMD_VEL_SAFE, self._on_cmd)
        self._single_command_source = ros_common.SinglePublisher(self, topics.CMD_VEL_SAFE)
        self.create_timer(float(p.diagnostics_period), self._publish_diagnostics)
        self.get_logger().info(
            f"gait controller for '{robot}' ({type(self.controller).__name__}), "
            f"period {self.controller.control_period * 1e3:.1f} ms"
        )

    def _apply_params(
        self, old: GaitControllerParams, new: GaitControllerParams, names: frozenset[str]
    ) -> None:
        """Use validated new stamp limits: the command timeout and the stamp gate."""
        self._timeout = float(new.command_timeout)
        self._gate = StampGate(float(new.max_future_stamp), self._timeout)

    # -- inputs -----------------------------------------------------------------------------
    def _state_time(self) -> float | None:
        return None if self._imu is None else ros_common.from_time_msg(self._imu.header.stamp)

    def _reject(self, topic: str, reason: str) -> None:
        self.rejected[f"{topic}_{reason}"] += 1
        self._dropped += 1
        self.get_logger().warn(f"rejected a {topic} message: {reason}", throttle_duration_sec=1.0)

    def _stamp_ok(self, topic: str, stamp) -> bool:  # noqa: ANN001 - builtin_interfaces/Time
        verdict = self._gate.verdict(ros_common.from_time_msg(stamp), ros_common.now_seconds(self))
        if verdict is StampVerdict.OK:
            return True
        self._reject(topic, verdict.value)
        return False

    def _on_cmd(self, msg: Twist) -> None:
        if not ros_common.twist_is_finite(msg):
            self._reject("cmd_vel_safe", "non_finite")
            return
        if not self._single_command_source.ok():
            self._reject("cmd_vel_safe", "second_publisher")
            self._command, self._command_time = VelocityCommand(), self._state_time()
            return
        self._command = ros_common.twist_to_command(msg)
        self._command_time = self._state_time()

    def _on_odom(self, msg: Odometry) -> None:
        if not ros_common.odometry_is_finite(msg):
            self._reject("odom", "non_finite")
            return
        if self._stamp_ok("odom", msg.header.stamp):
            self._odom = ros_common.odometry_to_base_state(msg)

    def _on_imu(self, msg: Imu) -> None:
        o, w = msg.orientation, msg.angular_velocity
        if not all(math.isfinite(v) for v in (o.x, o.y, o.z, o.w, w.x, w.y, w.z)) or not (
            o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w > 1e-6
        ):
            self._reject("imu", "non_finite")
            return
        if self._stamp_ok("imu", msg.header.stamp):
            self._note_state_gap(ros_common.from_time_msg(msg.header.stamp))
            self._imu = msg
            self._maybe_tick()

    def _note_state_gap(self, t: float) -> None:
        """Log a state that arrives more than 50 ms of wall time after the previous one.

        Once physics runs, states come every 4-5 ms of sim time; a long gap means the state
        did not reach this node (or its executor was held) and the motor drivers may damp.
        """
        now = time.monotonic()
        last, self._last_imu_wall = self._last_imu_wall, now
        running, self._last_imu_t = self._last_imu_t > 0.0, t
        if last is not None and running and now - last > _STATE_GAP:  # not the wait at t = 0
            self.get_logger().warn(
                f"no state for {(now - last) * 1e3:.0f} ms (wall) before the state of t={t:.3f} s"
            )

    def _on_joints(self, msg: JointState) -> None:
        if len(msg.position) != len(msg.name) or not all(
            math.isfinite(v) for v in (*msg.position, *msg.velocity)
        ):
            self._reject("joint_states", "non_finite")
            return
        if self._stamp_ok("joint_states", msg.header.stamp):
            self._joints = msg
            self._maybe_tick()

    def _base_state(self, t: float) -> BaseState:
        """Base state at ``t``: IMU attitude and rates, odometry position and velocity."""
        imu, odom = self._imu, self._odom
        o, w = imu.orientation, imu.angular_velocity
        state = BaseState(
            position=odom.position,
            orientation=(o.x, o.y, o.z, o.w),
            angular_velocity=(w.x, w.y, w.z),
            stamp=t,
        )
        v_world = odom.linear_velocity_world
        state.position = odom.position + v_world * max(0.0, t - odom.stamp)
        state.linear_velocity = state.rotation.T @ v_world
        return state

    # -- control ----------------------------------------------------------------------------
    def _joint_vectors(self, msg: JointState) -> tuple[np.ndarray, np.ndarray]:
        key = tuple(msg.name)
        if key != self._names_key:
            index = {n: i for i, n in enumerate(msg.name)}
            missing = [n for n in self.controller.joint_names if n not in index]
            if missing:
                raise KeyError(f"/joint_states lacks joints {missing}")
            self._names_index = np.array([index[n] for n in self.controller.joint_names])
            self._names_key = key
        q = np.asarray(msg.position, dtype=float)[self._names_index]
        dq = (
            np.asarray(msg.velocity, dtype=float)[self._names_index]
            if len(msg.velocity) == len(msg.name)
            else np.zeros(len(self._names_index))
        )
        return q, dq

    def _active_command(self, t: float) -> VelocityCommand:
        stale = self._command_time is None or t - self._command_time > self._timeout
        if stale and not self._command_stale:
            self.get_logger().warn("no /cmd_vel_safe within the timeout: stopping and standing")
        self._command_stale = stale
        return VelocityCommand() if stale else self._command

    def _maybe_tick(self) -> None:
        if self._imu is None or self._joints is None or self._odom is None:
            return
        t = ros_common.from_time_msg(self._imu.header.stamp)
        if ros_common.from_time_msg(self._joints.header.stamp) != t:
            return  # wait for the matching half of this state
        if t == self._last_processed_stamp:
            self._resend_if_republished()
            return
        if t < self._last_processed_stamp:
            return
        if self._holding_first_command():
            return
        period = self.controller.control_period
        if self._last_tick is not None and t - self._last_tick < period - 1e-9:
            return
        try:
            q, dq = self._joint_vectors(self._joints)
        except KeyError as err:
            self.get_logger().error(str(err), throttle_duration_sec=5.0)
            return
        base = self._base_state(t)
        start = time.perf_counter()
        cmd = self.controller.update(t, base, q, dq, self._active_command(t))
        took = time.perf_counter() - start
        self._tick_wall += took
        if took > self._tick_max:
            self._tick_max = took
            if took > _SLOW_TICK:
                self.get_logger().warn(f"slowest tick so far: {took * 1e3:.0f} ms at t={t:.3f} s")
        self._ticks += 1
        self._last_tick = t
        self._last_processed_stamp = t
        if not cmd.is_finite():
            self._dropped += 1
            self.get_logger().error("controller produced a non-finite command; not sent")
            return
        msg = MotorCommand()
        msg.header.stamp = self._imu.header.stamp
        msg.header.frame_id = topics.BASE_FRAME
        msg.name = list(cmd.names)
        msg.q, msg.dq, msg.kp, msg.kd, msg.tau = (
            cmd.q.tolist(), cmd.dq.tolist(), cmd.kp.tolist(), cmd.kd.tolist(), cmd.tau.tolist()
        )
        start = time.perf_counter()
        self._pub.publish(msg)
        took = time.perf_counter() - start
        if took > _SLOW_TICK:
            self.get_logger().warn(f"publishing the command for t={t:.3f} s took "
                                   f"{took * 1e3:.0f} ms")
        self._last_msg = msg
        self._answered = (self._imu, self._joints)

    def _holding_first_command(self) -> bool:
        """True while the first command waits for ``start_subscribers`` readers (wall-bounded).

        Physics starts with the first command; the simulator republishes its t = 0 state until
        then, so holding it lets a recorder match /joint_commands before any command goes out.
        """
        if not self._start_held:
            return False
        if self._pub.get_subscription_count() >= self._start_subscribers:
            self._start_held = False
            return False
        now = time.monotonic()
        if self._start_deadline is None:
            self._start_deadline = now + self._start_wait
        if now < self._start_deadline:
            return True
        self.get_logger().warn(
            f"/joint_commands has {self._pub.get_subscription_count()} of "
            f"{self._start_subscribers} subscribers after {self._start_wait:g} s: starting anyway"
        )
        self._start_held = False
        return False

    def _resend_if_republished(self) -> None:
        """Answer a state the simulator published again with the same command, once.

        The simulator republishes its state while it waits for a command (at t = 0 until
        the first command; see the simulator node). The command this node sent for it may
        have gone out before the publisher had matched the simulator's subscription, and
        time does not advance until one arrives: without this both would wait for good.
        """
        if self._answered is None:  # set together with _last_msg
            return
        imu, joints = self._answered
        if self._imu is imu or self._joints is joints:
            return  # the other half of the state already answered (or of its repetition)
        self._answered = (self._imu, self._joints)
        self._pub.publish(self._last_msg)

    def _publish_diagnostics(self) -> None:
        mean_ms = 1e3 * self._tick_wall / self._ticks if self._ticks else 0.0
        level = "warn" if self._command_stale else "ok"
        status = ros_common.diagnostic_status(
            "gait_controller",
            level,
            "command stale: standing" if self._command_stale else "tracking /cmd_vel_safe",
            {"ticks": self._ticks, "mean_tick_ms": f"{mean_ms:.3f}",
             "max_tick_ms": f"{self._tick_max * 1e3:.3f}", "dropped": self._dropped,
             **{f"rejected_{k}": n for k, n in sorted(self.rejected.items())}},
        )
        self._diag_pub.publish(ros_common.diagnostic_array(self, [status]))


def main(args: list[str] | None = None) -> int:
    """Run the gait controller node as its own process."""
    return ros_common.run_node(GaitControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
