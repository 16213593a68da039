"""One cycle of the C3BF safety filter node, without ROS: reference -> safe velocity command.

Per cycle (sim time ``t``):

1. Fail-safe checks: odometry older than ``odom_timeout`` or obstacles older than
   ``obstacles_timeout`` (or never received), or either stamped more than
   ``max_future_stamp`` ahead of ``t`` -> brake every velocity to zero at ``brake_decel``
   (STALE_INPUT). A reference older than ``reference_timeout`` (or from the future) -> the
   reference becomes zero (flagged, still filtered). An obstacle seen in the last
   ``vanished_memory`` s that is gone from the list while inside the robot's stopping
   distance -> brake to a stop (EMERGENCY_BRAKE; see ``filtering.vanished``).
2. Reference to acceleration: u_ref = k (v_ref - v), saturated (the paper's P tracking), where
   v is the commanded velocity held by this cycle's integrator (the model's velocity state).
3. The C3BF QP (``safe_legged_c3bf.c3bf.SafetyFilter``) over (a, alpha, a_z) for the unicycle
   model with body-point offset (the paper's) or (a_x, a_y, a_z) for the holonomic model,
   with vertical and horizontal obstacles together. Per-cycle input bounds add the velocity
   limits, a height-range barrier (never duck below ``min_height``: brake or steer instead)
   and anti-windup (no further integration in a direction where the command already leads
   the measured velocity, averaged over ``windup_window``, by more than ``windup_band``).
4. Integrate the safe acceleration into the published velocity command.

Frames: odom for positions and obstacles; the command is in base_link (REP-103). In the
unicycle model the command's linear.y is always 0: that model cannot vouch for side-steps.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from safe_legged_c3bf.c3bf import (
    FilterResult,
    FilterStatus,
    HolonomicHeightModel,
    InvalidInputError,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleLateralHeightModel,
)
from safe_legged_c3bf.c3bf.body import robot_body
from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.interfaces.rotations import yaw_from_quaternion
from safe_legged_c3bf.safety.deadlock_side import deadlock_side
from safe_legged_c3bf.safety.input_bounds import input_bounds, yaw_rate_only_decays
from safe_legged_c3bf.safety.moving_mean import MovingMean
from safe_legged_c3bf.safety.obstacle_input import (
    ObstacleInput,
    ObstacleSet,
    to_c3bf_obstacles_walled,
)
from safe_legged_c3bf.safety.params import LATERAL_MODELS, TURNING_MODELS, FilterParams
from safe_legged_c3bf.safety.reference_shaping import ReferenceShaping
from safe_legged_c3bf.safety.vanished import Vanished, VanishWatch


class CycleStatus(enum.IntEnum):
    """Status of a cycle; values equal the SafetyFilterState message constants."""

    PASS_THROUGH = 0
    INACTIVE = 1
    ACTIVE = 2
    RELAXED = 3
    EMERGENCY_BRAKE = 4
    STALE_INPUT = 5
    INVALID_INPUT = 6


_FROM_FILTER = {
    FilterStatus.INACTIVE: CycleStatus.INACTIVE,
    FilterStatus.ACTIVE: CycleStatus.ACTIVE,
    FilterStatus.RELAXED: CycleStatus.RELAXED,
    FilterStatus.EMERGENCY: CycleStatus.EMERGENCY_BRAKE,
    # FAILSAFE (the solver failed) is answered by braking at brake_decel: see _filtered.
}


@dataclass
class CycleOutput:
    """What one cycle produced.

    Attributes:
        command: the safe velocity command (base_link).
        status: what happened (see :class:`CycleStatus`).
        text: a human-readable reason.
        reference: the reference used (zero when stale).
        reference_stale: the reference was older than its timeout.
        u_reference, u_safe: the model inputs before and after filtering.
        result: the QP result (None when the QP did not run).
        obstacle_ids: ids of the constraints, in ``result`` order.

    """

    command: VelocityCommand
    status: CycleStatus
    text: str
    reference: VelocityCommand
    reference_stale: bool
    u_reference: np.ndarray = field(default_factory=lambda: np.zeros(0))
    u_safe: np.ndarray = field(default_factory=lambda: np.zeros(0))
    result: FilterResult | None = None
    obstacle_ids: list[str] = field(default_factory=list)


def _sat(x: float, limit: float) -> float:
    return max(-limit, min(limit, float(x)))  # (float: numpy scalars compare slowly)


def _toward_zero(x: float, step: float) -> float:
    return 0.0 if abs(x) <= step else x - math.copysign(step, x)


def _with_ref(text: str, ref_stale: bool) -> str:
    return text + " (reference stale: zero)" if ref_stale else text


def _fresh(age: float, timeout: float, max_future: float) -> bool:
    """True when a stamp ``age`` s old (negative: from the future) is usable."""
    return -max_future <= age <= timeout


class SafetyFilterCycle:
    """The safety filter's per-cycle logic, holding the commanded-velocity integrator."""

    def __init__(self, params: FilterParams | None = None) -> None:
        """Create the cycle with validated ``params`` (defaults if None)."""
        self.params = (params or FilterParams()).validate()
        self._build()
        # Commanded velocity (base_link): vx, vy, vz, yaw rate.
        self._v = np.zeros(4)
        self._initialised = False
        self._last_t: float | None = None
        # The anti-windup's measured velocity (``windup_window``).
        self._measured_mean = MovingMean(self.params.windup_window)
        # Deadlock resolution: turn side (+1 left, -1 right, 0 none), when last deadlocked,
        # and whether the last cycle's QP changed the command.
        self._detour_side = 0
        self._detour_time = -math.inf
        self._detour_until = -math.inf
        self._held_back = False
        # Obstacles seen recently, and the vanished one being braked for (if any).
        self._vanish_watch = VanishWatch()
        self._vanish_brake: Vanished | None = None

    def _build(self) -> None:
        p = self.params
        weights = list(p.weights)
        if p.model == "unicycle":
            model = UnicycleHeightModel(offset=p.offset)
            limits = np.array([p.max_accel, p.max_yaw_accel, p.max_vertical_accel])
        elif p.model == "unicycle_lateral":
            model = UnicycleLateralHeightModel(offset=p.offset)
            limits = np.array([p.max_accel, p.max_yaw_accel, p.max_vertical_accel, p.max_accel])
            weights.append(p.lateral_weight)
        else:
            model = HolonomicHeightModel()
            limits = np.array([p.max_accel, p.max_accel, p.max_vertical_accel])
        self._limits = limits
        self._body = robot_body(p.robot_body) if p.body_model == "body" else None
        self.filter = SafetyFilter(
            model, gamma=p.gamma, weights=np.array(weights), u_min=-limits, u_max=limits,
            body=self._body, exit_speed=p.exit_speed,
        )
        self.shaping = ReferenceShaping(p, self._body, self.filter.margin)
        # Static obstacles' sides: the cone steering's where it picks them, else the tie-break's.
        self._tie_break_speed = p.tie_break_speed if self.shaping.steers else 0.0

    def set_params(self, params: FilterParams) -> None:
        """Replace the parameters (validated) and rebuild the QP."""
        self.params = params.validate()
        self._build()
        self._measured_mean.window = self.params.windup_window

    def _inflation(self) -> tuple[float, float]:
        """Diameters [m] the obstacles grow by in x-y and x-z before the filter sees them.

        The whole-body filter grows them by each body point's radius itself: 0 here.
        """
        if self._body is not None:
            return 0.0, 0.0
        return self.params.robot_width, self.params.robot_height

    @property
    def _bar_half_width(self) -> float:
        """Half the robot's width [m] for the lateral extent of bars."""
        if self._body is not None:
            return self._body.half_width
        return 0.5 * self.params.robot_width

    @property
    def commanded(self) -> VelocityCommand:
        """The current commanded velocity."""
        vx, vy, vz, wz = self._v
        return VelocityCommand(vx, vy, vz, wz)

    # ------------------------------------------------------------------ helpers
    def _clip_velocity(self, v: np.ndarray) -> np.ndarray:
        p = self.params
        vy_max = p.max_lateral_speed if p.model in LATERAL_MODELS else 0.0
        return np.array(
            [
                min(max(v[0], -p.max_reverse_speed), p.max_speed),
                _sat(v[1], vy_max),
                _sat(v[2], p.max_vertical_speed),
                _sat(v[3], p.max_yaw_rate),
            ]
        )

    def _brake(self, dt: float) -> None:
        p = self.params
        step = p.brake_decel * dt
        self._v = np.array([_toward_zero(x, step) for x in self._v])

    @staticmethod
    def _measured(base: BaseState) -> tuple[np.ndarray, float]:
        """Measured (vx, vy, vz, yaw rate) (body-frame planar, odom vertical) and the yaw.

        Scalar math on the unit quaternion: the formulas of ``BaseState.yaw`` and
        ``BaseState.linear_velocity_world`` without building the rotation matrix.
        """
        qx, qy, qz, qw = base.orientation.tolist()
        norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
        yaw = yaw_from_quaternion(qx, qy, qz, qw)
        vx, vy, vz = base.linear_velocity.tolist()
        vz_world = (2 * (qx * qz - qy * qw) * vx + 2 * (qy * qz + qx * qw) * vy
                    + (1 - 2 * (qx * qx + qy * qy)) * vz)
        return np.array([vx, vy, vz_world, float(base.angular_velocity[2])]), yaw

    # ------------------------------------------------------------------ the cycle
    def step(
        self,
        t: float,
        reference: VelocityCommand | None,
        reference_time: float | None,
        base: BaseState | None,
        obstacles: ObstacleSet | Sequence[ObstacleInput] | None,
        obstacles_time: float | None,
    ) -> CycleOutput:
        """Run one cycle at sim time ``t`` (s) and return the command to publish.

        Args:
            t: current sim time (s).
            reference: latest reference command (None if never received).
            reference_time: sim time the reference was received (s).
            base: latest odometry (None if never received); ``base.stamp`` is its time.
            obstacles: latest obstacle list (None if never received): best an
                :class:`ObstacleSet`, validated once when the list arrived; a list of
                :class:`ObstacleInput` is validated every cycle.
            obstacles_time: stamp of the obstacle list (s).

        """
        p = self.params
        dt = self._advance(t)
        ref_stale = reference is None or reference_time is None or not _fresh(
            t - reference_time, p.reference_timeout, p.max_future_stamp
        )
        ref = VelocityCommand() if ref_stale else reference
        if not p.enabled:
            self._v = ref.as_array()
            self._initialised = False
            text = "filter disabled: reference passed through"
            return CycleOutput(ref, CycleStatus.PASS_THROUGH, _with_ref(text, ref_stale), ref,
                               ref_stale)
        stale = self._stale_inputs(t, base, obstacles, obstacles_time)
        if stale:
            return self._braked(dt, CycleStatus.STALE_INPUT, f"{stale} stale: braking to zero",
                                ref, ref_stale)
        measured, yaw = self._measured(base)
        if not self._initialised:
            self._v = self._clip_velocity(measured)
            self._initialised = True
        windup_measured = self._measured_mean.add(t, measured)
        pos = base.position
        try:  # obstacles predicted to now from their stamp
            circles, ids, walled = to_c3bf_obstacles_walled(
                obstacles, t - obstacles_time, float(pos[1]), *self._inflation(),
                p.safety_margin, p.horizontal_y_margin, yaw, p.tie_break, self._bar_half_width,
                self.shaping.walls, float(pos[0]), t, self._tie_break_speed,
            )
        except InvalidInputError as err:
            return self._braked(dt, CycleStatus.INVALID_INPUT, f"rejected obstacles: {err}",
                                ref, ref_stale)
        vanished = self._check_vanished(t, obstacles, pos, yaw)
        self._vanish_watch.observe(t, ids, circles)
        if vanished is not None:
            out = self._braked(
                dt, CycleStatus.EMERGENCY_BRAKE,
                f"obstacle '{vanished.obstacle_id}' vanished {vanished.clearance:.2f} m away, "
                f"inside the stopping distance {vanished.stopping_distance:.2f} m: braking "
                "to a stop", ref, ref_stale,
            )
            if not self._v.any():  # stopped: the vanished obstacle has been answered
                self._vanish_brake = None
            return out
        return self._filtered(t, dt, ref, ref_stale, pos, yaw, windup_measured, circles, ids,
                              walled)

    def _advance(self, t: float) -> float:
        """The integration step of the cycle at ``t`` (s).

        Nominal at first; never 0 (two cycles at one stamp, or time going back: a quarter
        period) nor more than two periods (the integrator must not leap).
        """
        period = 1.0 / self.params.rate
        last, self._last_t = self._last_t, t
        return period if last is None else min(max(t - last, 0.25 * period), 2.0 * period)

    def _stale_inputs(self, t: float, base, obstacles, obstacles_time) -> str:  # noqa: ANN001
        """'odometry', 'obstacles', both joined by 'and', or '' when both are fresh."""
        p = self.params
        odom_stale = base is None or not _fresh(
            t - base.stamp, p.odom_timeout, p.max_future_stamp
        )
        obstacles_stale = obstacles is None or obstacles_time is None or not _fresh(
            t - obstacles_time, p.obstacles_timeout, p.max_future_stamp
        )
        return " and ".join(
            n for n, s in (("odometry", odom_stale), ("obstacles", obstacles_stale)) if s
        )

    def _braked(
        self, dt: float, status: CycleStatus, text: str, ref: VelocityCommand, ref_stale: bool,
        u_ref: np.ndarray | None = None,
    ) -> CycleOutput:
        """Brake every velocity towards zero at ``brake_decel`` and say why."""
        self._brake(dt)
        out = CycleOutput(self.commanded, status, text, ref, ref_stale)
        if u_ref is not None:
            out.u_reference = u_ref
        return out

    def _model_problem(
        self, ref_arr: np.ndarray, pos: np.ndarray, yaw: float, gain: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int]]:
        """The QP's state, reference input and integrated velocity index per input.

        The reference input is u_ref = k (v_ref - v), saturated at the input limits; ``gain``
        [1/s] replaces every k of the planar velocities (an escape: reach it at full
        acceleration).
        """
        p, v = self.params, self._v
        k_v, k_w = (p.k_v, p.k_w) if gain is None else (gain, gain)
        if p.model in TURNING_MODELS:  # inputs (a, alpha, a_z[, a_l]) -> vx, wz, vz[, vy]
            state = [pos[0], pos[1], yaw, v[0], v[3], pos[2], v[2]]
            if p.model == "unicycle_lateral":
                state.append(v[1])
            state = np.array(state)
            gains = ((k_v, 0, p.max_accel), (k_w, 3, p.max_yaw_accel))
        else:  # inputs (a_x, a_y, a_z) -> vx, vy, vz
            c, s = math.cos(yaw), math.sin(yaw)
            state = np.array(
                [pos[0], pos[1], c * v[0] - s * v[1], s * v[0] + c * v[1], pos[2], v[2]]
            )
            gains = ((k_v, 0, p.max_accel), (k_v, 1, p.max_accel))
        gains += ((p.k_z, 2, p.max_vertical_accel),)
        if p.model == "unicycle_lateral":
            gains += ((k_v, 1, p.max_accel),)
        u_ref = np.array([_sat(k * (ref_arr[j] - v[j]), limit) for k, j, limit in gains])
        return state, u_ref, tuple(j for _, j, _ in gains)

    def _filtered(  # noqa: ANN001 - circles: c3bf Obstacles
        self, t, dt, ref, ref_stale, pos, yaw, measured, circles, ids, walled
    ) -> CycleOutput:
        """The C3BF QP on the reference, integrated into the command (fresh inputs).

        The whole body's reference is shaped first (``reference_shaping``); ``walled``: mask
        of the circles of bars handed over as walls (``bar_walls``); ``measured``: the
        velocity the anti-windup compares the command with (``windup_window``).
        """
        p, v = self.params, self._v
        ref_arr = ref.as_array()  # vx, vy, vz, wz
        shaped, escape = self.shaping.shape(t, ref_arr, circles, ids, walled, pos, yaw,
                                            float(v[0]), float(v[3]))
        deadlocked = (p.model in TURNING_MODELS and self._body is None  # body: cone steering
                      and self._deadlock_turn(t, ref_arr, circles, pos, yaw))
        state, u_ref, idx = self._model_problem(ref_arr, pos, yaw, 1.0 / dt if escape else None)
        u_min, u_max = self._bounds(v, measured, float(pos[2]), dt, idx, float(ref_arr[0]))
        if escape and p.model in LATERAL_MODELS:  # (the plain unicycle's escape turns)
            yaw_rate_only_decays(u_min, u_max, float(v[3]), dt, idx)
        u_ref_clipped = np.minimum(np.maximum(u_ref, u_min), u_max)  # np.clip, less overhead
        try:
            result = self.filter.filter(
                state, u_ref_clipped, circles, yaw=yaw, u_min=u_min, u_max=u_max
            )
        except InvalidInputError as err:
            return self._braked(dt, CycleStatus.INVALID_INPUT, f"rejected input: {err}", ref,
                                ref_stale, u_ref)
        if result.status is FilterStatus.FAILSAFE:  # the solver failed: brake, known profile
            return self._braked(dt, CycleStatus.EMERGENCY_BRAKE,
                                _with_ref(f"{result.message}: braking", ref_stale), ref,
                                ref_stale, u_ref)
        u = result.u_safe
        new_v = v.copy()
        for k, j in enumerate(idx):
            new_v[j] = v[j] + u[k] * dt
        if p.model == "unicycle":
            new_v[1] = 0.0
        elif p.model == "holonomic":
            new_v[3] = ref_arr[3]  # yaw does not move the holonomic body point
        self._v = self._clip_velocity(new_v)
        status = _FROM_FILTER[result.status]
        self._held_back = status is not CycleStatus.INACTIVE
        text = result.message or status.name.lower()
        text += shaped
        if deadlocked:
            text += f" (deadlock: turning {'left' if self._detour_side > 0 else 'right'})"
        return CycleOutput(
            self.commanded, status, _with_ref(text, ref_stale), ref, ref_stale, u_ref,
            u.copy(), result, ids,
        )

    def _check_vanished(self, t: float, obstacles, pos: np.ndarray, yaw: float):  # noqa: ANN001
        """The vanished obstacle to brake for (kept until the robot has stopped), or None."""
        if self._vanish_brake is not None:
            return self._vanish_brake
        p = self.params
        present = obstacles.ids if isinstance(obstacles, ObstacleSet) else [
            o.id for o in obstacles
        ]
        offset = p.offset if p.model in TURNING_MODELS else 0.0
        body_xy = (pos[0] + offset * math.cos(yaw), pos[1] + offset * math.sin(yaw))
        speed = math.hypot(self._v[0], self._v[1])
        stopping = speed * speed / (2.0 * p.brake_decel) + speed / p.rate
        self._vanish_brake = self._vanish_watch.check(
            t, present, body_xy, (body_xy[0], float(pos[2])), stopping, p.safety_margin,
            p.vanished_memory,
        )
        return self._vanish_brake

    def _deadlock_turn(
        self, t: float, ref_arr: np.ndarray, circles, pos: np.ndarray, yaw: float  # noqa: ANN001
    ) -> bool:
        """Deadlock resolution: replace the reference yaw rate by a turn in place if stuck.

        Deadlocked: the filter changed the last command and holds the robot still (commanded
        speed below ``deadlock_speed``, yaw rate below half ``deadlock_yaw_rate``) while the
        reference asks to move or to turn. At rest every barrier is 0 and its gradient only
        forbids body-point motion towards each obstacle, so the QP can hold the robot still
        for good (an undesired equilibrium of CBF-QPs): in front of an obstacle, or between
        obstacles that each block one way of turning. The reference (not the constraint) then
        turns in place for at least ``deadlock_turn_time`` s, to the side whose body-point
        motion points most away from the obstacles within 1 m of their inflated circles (the
        side that passes the nearest one as the tie-break does when that is a tie). The side
        is kept for ``deadlock_memory`` s so noise cannot make the robot dither. The QP still
        filters the turn. Modifies ``ref_arr`` in place; returns True when it did.
        """
        p = self.params
        if p.deadlock_yaw_rate <= 0.0:
            return False
        v = self._v
        if t < self._detour_until and v[0] < 2.0 * p.deadlock_speed:
            ref_arr[3] = self._detour_side * p.deadlock_yaw_rate
            return True
        stuck = (self._held_back and abs(v[0]) < p.deadlock_speed
                 and abs(v[3]) < 0.5 * p.deadlock_yaw_rate
                 and (ref_arr[0] > p.deadlock_speed
                      or abs(ref_arr[3]) > 0.5 * p.deadlock_yaw_rate))
        if not stuck:
            return False
        if self._detour_side == 0 or t - self._detour_time > p.deadlock_memory:
            side = deadlock_side(circles, pos, yaw, p.offset)
            if side == 0:
                return False
            self._detour_side = side
        self._detour_time = t
        self._detour_until = t + p.deadlock_turn_time
        ref_arr[3] = self._detour_side * p.deadlock_yaw_rate
        return True

    def _bounds(
        self, v: np.ndarray, measured: np.ndarray, z: float, dt: float, idx: tuple[int, ...],
        ref_vx: float = math.inf,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per-cycle input bounds (``input_bounds``; whole body: forward speed capped)."""
        return input_bounds(self.params, self._limits, self._body is not None, v, measured, z,
                            dt, idx, ref_vx)
