"""Quadruped (A1) gait controller: trot schedule + convex MPC + swing-leg control.

Every :meth:`QuadrupedMpcController.update` (``control_period``, default 2 ms):

1. the command is clipped to the limits and rate-limited (smooth start and stop); ``vz`` is
   integrated into a body-height target clamped to [min_body_height, max_body_height];
2. the trot schedule advances (it stands when no motion has been asked for ``stand_delay``);
3. at ``mpc_period`` intervals, and whenever the planned contacts change, the convex MPC
   computes the ground reaction forces of the stance feet over the horizon;
4. stance legs get the feed-forward torques ``tau = -J^T R^T f`` (J: foot Jacobian in
   base_link, R: base_link -> odom, f: force of the ground on the foot in odom) plus a small
   joint damping towards the joint velocities of the commanded body motion; swing legs
   follow the swing trajectory towards the Raibert foothold through inverse kinematics and
   joint PD; every leg also gets the torques that hold its own weight (the MPC's lumped
   body includes the legs, so without them the feet would not produce the planned forces).

Slow integral action on the body height, the velocity and the yaw rate removes the steady
state errors the lumped model leaves (the command filter and the integral action are in
:mod:`~safe_legged_c3bf.gait.quadruped.command_shaping`).

The returned :class:`JointCommand` is meant for motor drivers that apply
``tau = kp (q* - q) + kd (dq* - dq) + tau_ff`` at a higher rate. The controller holds no ROS
objects; a zero command (what the node feeds on command timeout) stops and stands the robot.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from safe_legged_c3bf.gait.quadruped import a1_kinematics as kin
from safe_legged_c3bf.gait.quadruped.command_shaping import CommandFilter, IntegralAction
from safe_legged_c3bf.gait.quadruped.convex_mpc import ConvexMpc, MpcSolution
from safe_legged_c3bf.gait.quadruped.gait_schedule import GaitMode, TrotSchedule
from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams
from safe_legged_c3bf.gait.quadruped.state_estimate import (
    BodyEstimate,
    GroundHeightFilter,
    estimate_body,
)
from safe_legged_c3bf.gait.quadruped.swing import raibert_foothold, swing_point
from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.interfaces.joint_command import JointCommand
from safe_legged_c3bf.interfaces.rotations import wrap_angle

#: the package's parameter file (in the config directory)
DEFAULT_CONFIG = "quadruped_controller.yaml"
_GRAVITY = 9.81
#: time constant of the ground-height filter (s)
_GROUND_TIME_CONSTANT = 0.1
#: horizontal foot positions in base_link of the nominal stance (below the thigh joints)
_NOMINAL_XY = kin.nominal_foot_positions(0.3)[:, :2]
_NOMINAL_XY_LIST = _NOMINAL_XY.tolist()


class QuadrupedMpcController:
    """Convex-MPC trot controller for the A1, implementing the ``GaitController`` protocol."""

    def __init__(self, params: QuadrupedParams | None = None) -> None:
        """Create the controller (standing) with ``params`` (defaults if None)."""
        self.params = p = params if params is not None else QuadrupedParams()
        p.validate()
        self.joint_names: list[str] = list(kin.JOINT_NAMES)
        self.control_period: float = p.control_period
        weights = np.concatenate(
            [
                p.weight_orientation,
                p.weight_position,
                p.weight_angular_velocity,
                p.weight_linear_velocity,
            ]
        )
        self._mpc = ConvexMpc(
            mass=p.mass,
            inertia=np.array(p.inertia).reshape(3, 3),
            horizon=p.mpc_horizon,
            dt=p.mpc_dt,
            friction_coefficient=p.friction_coefficient,
            min_normal_force=p.min_normal_force,
            max_normal_force=p.max_normal_force,
            state_weights=weights,
            force_weight=p.weight_force,
            eps_abs=p.osqp_eps_abs,
            eps_rel=p.osqp_eps_rel,
            max_iter=p.osqp_max_iter,
        )
        self._gait = TrotSchedule(p.gait_period, p.duty_factor, p.stand_delay)
        self._ground = GroundHeightFilter(_GROUND_TIME_CONSTANT, p.foot_radius)
        self._com_offset = np.array(p.com_offset, dtype=float)
        self._command_filter = CommandFilter(
            [p.max_forward_speed, p.max_lateral_speed, p.max_yaw_rate],
            [p.max_linear_acceleration, p.max_linear_acceleration, p.max_yaw_acceleration],
        )
        self._integral = IntegralAction(p)
        n = p.mpc_horizon
        self._k_states = np.arange(1, n + 1, dtype=float)
        self._k_inputs = np.arange(n, dtype=float)
        #: wall-clock durations (s) of the MPC solves (update + solve), most recent last
        self.mpc_solve_times: deque[float] = deque(maxlen=200_000)
        self.reset()

    @classmethod
    def from_config(cls, config_file: str | None = None) -> QuadrupedMpcController:
        """Build the controller from a YAML parameter file.

        Args:
            config_file: path of a flat or ROS 2 parameter-file YAML (relative paths are
                looked up in the package's config directory); None loads the package's
                ``config/quadruped_controller.yaml``.

        """
        return cls(QuadrupedParams.from_yaml(config_file or DEFAULT_CONFIG))

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget the past: stand, and re-initialise the height target at the next update."""
        self._gait.reset()
        self._ground.reset()
        self._t_prev: float | None = None
        self._command_filter.reset()
        self._integral.reset()
        self._height: float | None = None
        self._height_rate = 0.0
        self._forces = np.zeros((4, 3))
        self._last_mpc_time = -np.inf
        self._prev_contacts = np.ones(4, dtype=bool)
        self.last_footholds = np.zeros((4, 3))
        self._liftoff = np.zeros((4, 3))
        self._anchor: tuple[float, float, float] | None = None
        self.mpc_failures = 0
        self.mpc_solves = 0
        self.last_solution: MpcSolution | None = None

    @property
    def mode(self) -> GaitMode:
        """Current gait mode (STAND or TROT)."""
        return self._gait.mode

    @property
    def height_target(self) -> float | None:
        """Current body-height target above the ground (m), None before the first update."""
        return self._height

    @property
    def ground_height(self) -> float | None:
        """Current ground-height estimate (m, odom z), None before the first update."""
        return self._ground.height

    @property
    def filtered_command(self) -> np.ndarray:
        """The rate-limited (vx, vy, yaw_rate) being tracked."""
        return self._command_filter.value.copy()

    # ------------------------------------------------------------------ update
    def update(
        self,
        t: float,
        base: BaseState,
        q: np.ndarray,
        dq: np.ndarray,
        command: VelocityCommand,
    ) -> JointCommand:
        """Return the motor command for time ``t`` (s) given the measured state.

        Steps: input check and time step, state estimate, command filtering, gait phase,
        ground and height target, integral action, swing footholds, MPC (when due), and the
        joint command (stance and swing targets, feed-forward torques, gains).
        """
        q = np.asarray(q, dtype=float).reshape(12)
        dq = np.asarray(dq, dtype=float).reshape(12)
        if not _inputs_finite(t, base, q, dq):
            return self._damping_command(q)
        dt = self._advance_clock(t)

        # ---- state estimate
        body = estimate_body(base, self._com_offset)
        feet_b, jac = kin.leg_kinematics(q)
        feet_w = feet_b @ body.rotation.T + body.position

        # ---- command, gait phase, ground and height target
        vx, vy, wz = self._command_filter.update(command, dt)
        contacts, progress, t_td = self._advance_gait(t, body, feet_w)
        ground = self._update_height_target(command, body, feet_w, contacts, dt)
        trotting = self._gait.mode is GaitMode.TROT

        # ---- integral action on the height, velocity and yaw-rate references
        yaw = body.yaw
        cy, sy = math.cos(yaw), math.sin(yaw)
        height_error = self._height - (float(body.position[2]) - ground)
        settled = self._command_filter.settled
        vx, vy, wz = self._integral.update(
            height_error, body, dt, trotting, settled, cy, sy, vx, vy, wz
        )
        v_des_w = np.array([cy * vx - sy * vy, sy * vx + cy * vy, self._height_rate])

        # ---- swing feet: footholds (odom) of the legs in the air
        air_legs = [i for i, c in enumerate(contacts.tolist()) if not c] if trotting else []
        if air_legs:
            self._update_footholds(air_legs, body, t_td, v_des_w, wz, ground)

        # ---- MPC: at mpc_period intervals, at contact changes and at the first update
        changed = bool((contacts != self._prev_contacts).any())
        if (
            t - self._last_mpc_time >= self.params.mpc_period - 1e-9
            or changed
            or self.last_solution is None
        ):
            self._solve_mpc(body, feet_w, self.last_footholds, ground, wz, vx, vy)
            self._last_mpc_time = t
        self._prev_contacts = contacts

        # ---- joint commands
        return self._joint_command(
            q, body, feet_b, feet_w, jac, contacts, progress, air_legs, ground, v_des_w, wz
        )

    def _advance_clock(self, t: float) -> float:
        """Return the time step (s) since the last update, at most 0.05 s.

        It is 0 at the first update, and when ``t`` went backwards (the controller resets).
        """
        if self._t_prev is None or t < self._t_prev - 1e-9:
            if self._t_prev is not None:
                self.reset()
            dt = 0.0
        else:
            dt = min(t - self._t_prev, 0.05)
        self._t_prev = t
        return dt

    def _advance_gait(
        self, t: float, body: BodyEstimate, feet_w: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance the trot schedule; return its (contacts, swing progress, time to touch-down).

        Also records the lift-off points of the legs that just left the ground, and the
        standing anchor (centre of mass x, y and yaw held while standing).
        """
        self._gait.update(t, self._command_filter.motion_requested)
        contacts, progress, t_td = self._gait.snapshot()
        lifted = self._prev_contacts & ~contacts  # _prev_contacts: set by update() after MPC
        self._liftoff[lifted] = feet_w[lifted]
        if self._gait.mode is not GaitMode.TROT:
            if self._anchor is None:
                self._anchor = (float(body.com[0]), float(body.com[1]), body.yaw)
        else:
            self._anchor = None
        return contacts, progress, t_td

    def _update_height_target(
        self,
        command: VelocityCommand,
        body: BodyEstimate,
        feet_w: np.ndarray,
        contacts: np.ndarray,
        dt: float,
    ) -> float:
        """Update the ground estimate and integrate ``vz`` into the height target; return ground.

        The target starts at the measured height and stays within [min_body_height,
        max_body_height]; ``_height_rate`` is its rate of change over this step.
        """
        p = self.params
        vz = float(command.vz) if math.isfinite(command.vz) else 0.0
        vz = min(p.max_vertical_speed, max(-p.max_vertical_speed, vz))
        ground = self._ground.update(feet_w, contacts, dt)
        if self._height is None:
            self._height = min(
                p.max_body_height, max(p.min_body_height, float(body.position[2]) - ground)
            )
        new_height = min(p.max_body_height, max(p.min_body_height, self._height + vz * dt))
        self._height_rate = (new_height - self._height) / dt if dt > 0 else 0.0
        self._height = new_height
        return ground

    def _update_footholds(
        self,
        legs: list[int],
        body: BodyEstimate,
        t_td: np.ndarray,
        v_des_w: np.ndarray,
        wz: float,
        ground: float,
    ) -> None:
        """Write the Raibert footholds (odom) of ``legs`` into ``last_footholds``."""
        p = self.params
        px, py = float(body.position[0]), float(body.position[1])
        vdx, vdy = float(v_des_w[0]), float(v_des_w[1])
        velocity = (float(body.velocity[0]), float(body.velocity[1]))
        yaw = body.yaw
        foot_z = ground + p.foot_radius
        for leg in legs:
            t_leg = float(t_td[leg])
            c, s = math.cos(yaw + wz * t_leg), math.sin(yaw + wz * t_leg)
            nx, ny = _NOMINAL_XY_LIST[leg]
            nwx, nwy = c * nx - s * ny, s * nx + c * ny
            fx, fy = raibert_foothold(
                (px + vdx * t_leg + nwx, py + vdy * t_leg + nwy),
                (vdx - wz * nwy, vdy + wz * nwx),
                velocity,
                (vdx, vdy),
                wz,
                self._gait.stance_duration,
                self._height,
                p.foothold_velocity_gain,
                p.max_foothold_offset,
            )
            self.last_footholds[leg] = (fx, fy, foot_z)

    def _swing_targets(
        self,
        legs: list[int],
        body: BodyEstimate,
        progress: np.ndarray,
        q_cmd: np.ndarray,
        foot_vb: np.ndarray,
    ) -> None:
        """Write swing legs' joint targets into ``q_cmd``, foot velocities into ``foot_vb``.

        Foot velocities are relative to the body, in base_link axes.
        """
        p = self.params
        r = body.rotation.tolist()
        bx, by, bz = body.position.tolist()
        vx, vy, vz = body.velocity.tolist()
        wx, wy, wz = body.angular_velocity.tolist()
        duration = self._gait.swing_duration
        for leg in legs:
            pos, vel = swing_point(
                self._liftoff[leg].tolist(),
                self.last_footholds[leg].tolist(),
                float(progress[leg]),
                duration,
                p.swing_height,
            )
            rx, ry, rz = pos[0] - bx, pos[1] - by, pos[2] - bz
            ux = vel[0] - vx - (wy * rz - wz * ry)
            uy = vel[1] - vy - (wz * rx - wx * rz)
            uz = vel[2] - vz - (wx * ry - wy * rx)
            # rotate odom -> base_link (R^T)
            foot_b = (
                r[0][0] * rx + r[1][0] * ry + r[2][0] * rz,
                r[0][1] * rx + r[1][1] * ry + r[2][1] * rz,
                r[0][2] * rx + r[1][2] * ry + r[2][2] * rz,
            )
            foot_vb[leg] = (
                r[0][0] * ux + r[1][0] * uy + r[2][0] * uz,
                r[0][1] * ux + r[1][1] * uy + r[2][1] * uz,
                r[0][2] * ux + r[1][2] * uy + r[2][2] * uz,
            )
            q_cmd[3 * leg : 3 * leg + 3] = kin.leg_inverse_kinematics(leg, foot_b)

    def _joint_command(
        self,
        q: np.ndarray,
        body: BodyEstimate,
        feet_b: np.ndarray,
        feet_w: np.ndarray,
        jac: np.ndarray,
        contacts: np.ndarray,
        progress: np.ndarray,
        air_legs: list[int],
        ground: float,
        v_des_w: np.ndarray,
        wz: float,
    ) -> JointCommand:
        """Assemble the motor command from the stance and swing targets and the MPC forces.

        Stance legs: joint velocities that keep the feet put in odom while the body moves at
        ``v_des_w`` and ``wz`` (for the damping), posture targets when ``stance_kp`` > 0, and
        the torques ``-J^T R^T f`` of the MPC forces. Swing legs: the swing trajectory's
        joint targets and velocities. Every leg: the torques that hold its own weight.
        """
        p = self.params
        rot = body.rotation
        jinv = kin.jacobian_inverses(jac)
        wb0, wb1, wb2 = (rot[2] * wz).tolist()  # R^T (0, 0, wz)
        v_des_b = v_des_w @ rot
        # stance feet stay put in odom while the body moves as commanded
        foot_vb = np.empty((4, 3))
        fx, fy, fz = feet_b[:, 0], feet_b[:, 1], feet_b[:, 2]
        foot_vb[:, 0] = -v_des_b[0] - (wb1 * fz - wb2 * fy)
        foot_vb[:, 1] = -v_des_b[1] - (wb2 * fx - wb0 * fz)
        foot_vb[:, 2] = -v_des_b[2] - (wb0 * fy - wb1 * fx)
        q_cmd = q.copy() if p.stance_kp == 0.0 else self._stance_posture(body, feet_w, ground)
        if air_legs:
            self._swing_targets(air_legs, body, progress, q_cmd, foot_vb)
        dq_cmd = (jinv @ foot_vb[:, :, None]).reshape(12)
        f_body = self._forces @ rot
        tau = -(f_body[:, None, :] @ jac).reshape(4, 3)
        tau[~contacts] = 0.0
        tau = tau.reshape(12) + kin.gravity_torques(q, rot[2] * -_GRAVITY)
        stance_j = np.repeat(contacts, 3)
        kp = np.where(stance_j, p.stance_kp, p.swing_kp)
        kd = np.where(stance_j, p.stance_kd, p.swing_kd)
        return JointCommand(self.joint_names, q_cmd, dq_cmd, kp, kd, tau)

    def _stance_posture(self, body: BodyEstimate, feet_w: np.ndarray, ground: float) -> np.ndarray:
        """Joint targets that put the body level at the target height over the feet."""
        yaw = body.yaw
        cy, sy = math.cos(yaw), math.sin(yaw)
        p_des = np.array([body.position[0], body.position[1], ground + self._height])
        rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        return kin.inverse_kinematics((feet_w - p_des) @ rz)

    # ------------------------------------------------------------------ helpers
    def _solve_mpc(
        self,
        body: BodyEstimate,
        feet_w: np.ndarray,
        footholds: np.ndarray,
        ground: float,
        wz: float,
        vx: float,
        vy: float,
    ) -> None:
        """Build the MPC references and foot vectors, solve, and store the forces."""
        p = self.params
        n, dt = p.mpc_horizon, p.mpc_dt
        yaw = body.yaw
        contacts_plan, touchdowns = self._gait.plan(n, dt)
        x_ref = np.zeros((n, 12))
        yaw_states = yaw + wz * dt * self._k_states
        yaw_inputs = yaw + wz * dt * self._k_inputs
        # horizontal path of the centre of mass under the rate-limited command
        yaw_mid = yaw + wz * dt * (self._k_inputs + 0.5)
        c_mid, s_mid = np.cos(yaw_mid), np.sin(yaw_mid)
        vel_xy = np.stack([c_mid * vx - s_mid * vy, s_mid * vx + c_mid * vy], axis=1)
        if self._anchor is not None:
            x_ref[:, 0:3] = (0.0, 0.0, yaw + wrap_angle(self._anchor[2] - yaw))
            x_ref[:, 3:5] = self._anchor[:2]
        else:
            x_ref[:, 2] = yaw_states
            x_ref[:, 3:5] = body.com[:2] + np.cumsum(vel_xy * dt, axis=0)
            x_ref[:, 8] = wz
            c_s, s_s = np.cos(yaw_states), np.sin(yaw_states)
            x_ref[:, 9] = c_s * vx - s_s * vy
            x_ref[:, 10] = s_s * vx + c_s * vy
        heights = np.clip(
            self._height + self._height_rate * dt * self._k_states,
            p.min_body_height,
            p.max_body_height,
        )
        x_ref[:, 5] = ground + heights + self._integral.height_correction + self._com_offset[2]
        x_ref[:, 11] = np.diff(np.concatenate([[self._height], heights])) / dt

        # centre of mass at the input steps k = 0..N-1
        com_path = np.empty((n, 3))
        com_path[0] = body.com
        com_path[1:] = x_ref[:-1, 3:6]
        # planned foot positions at each input step
        c_in, s_in = np.cos(yaw_inputs), np.sin(yaw_inputs)
        rel = _NOMINAL_XY - self._com_offset[:2]  # (4, 2)
        pred = np.empty((n, 4, 3))
        pred[:, :, 0] = com_path[:, None, 0] + c_in[:, None] * rel[:, 0] - s_in[:, None] * rel[:, 1]
        pred[:, :, 1] = com_path[:, None, 1] + s_in[:, None] * rel[:, 0] + c_in[:, None] * rel[:, 1]
        pred[:, :, :2] += vel_xy[:, None, :] * (0.5 * self._gait.stance_duration)
        pred[:, :, 2] = ground + p.foot_radius
        stance_now = self._gait.contacts()
        use_current = stance_now[None, :] & (touchdowns == 0)
        use_target = ~stance_now[None, :] & (touchdowns == 1)
        planned = np.where(use_current[..., None], feet_w[None], pred)
        planned = np.where(use_target[..., None], footholds[None], planned)
        foot_vectors = planned - com_path[:, None, :]

        x0 = np.concatenate([body.rpy, body.com, body.angular_velocity, body.com_velocity])
        solution = self._mpc.solve(x0, x_ref, yaw_inputs, foot_vectors, contacts_plan)
        self.mpc_solves += 1
        if not solution.ok:
            self.mpc_failures += 1
        self.mpc_solve_times.append(solution.solve_time)
        self.last_solution = solution
        self._forces = solution.forces

    def _damping_command(self, q: np.ndarray) -> JointCommand:
        """Joint damping only, used when the measured state is not finite."""
        p = self.params
        q_safe = np.where(np.isfinite(q), q, kin.STANDING_POSE)
        zeros = np.zeros(12)
        return JointCommand(
            self.joint_names, q_safe, zeros, zeros, np.full(12, p.fault_damping_kd), zeros.copy()
        )


def _inputs_finite(t: float, base: BaseState, q: np.ndarray, dq: np.ndarray) -> bool:
    """True when the time, the base state and the joint states are all finite."""
    checksum = (
        base.position.sum()
        + base.orientation.sum()
        + base.linear_velocity.sum()
        + base.angular_velocity.sum()
        + q.sum()
        + dq.sum()
    )
    return math.isfinite(float(checksum)) and math.isfinite(t)
