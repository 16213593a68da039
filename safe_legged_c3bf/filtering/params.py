"""Parameters of the safety filter node, with units, defaults and validation.

Every value is SI (m, s, rad). ``validate`` names the first bad parameter, so the node can
reject a bad ``ros2 param set`` with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

MODELS = ("unicycle", "holonomic")


@dataclass(frozen=True)
class FilterParams:
    """Safety filter parameters (SI units; frames: odom for obstacles, base_link for commands).

    Attributes:
        enabled: False = pass-through (baseline runs), flagged PASS_THROUGH.
        model: 'unicycle' (the paper's, with body-point offset ``offset``) or 'holonomic'.
        offset: body-point offset l ahead of the robot's centre (m), unicycle only: larger
            gives more steering authority but a larger circle to enclose the robot.
        gamma: class-K gain in Lf h + Lg h u + gamma h >= 0 (1/s); the paper uses 1.
        robot_width: w in the paper's r = max(c1, c2) + w/2 (m): the diameter of the circle
            around the body point that encloses the robot's footprint (legs included). For a
            long robot this is its circumscribed diameter, not its narrow width: a circle of
            half the width would leave the rear exposed to crossing obstacles.
        robot_height: robot body height (m); horizontal obstacles grow by robot_height/2.
        safety_margin: extra inflation of every obstacle radius (m).
        rate: filter cycles per second (Hz) of sim time.
        k_v, k_w, k_z: reference tracking gains (1/s): u_ref = k (v_ref - v).
        max_accel: |a| limit on forward/lateral acceleration (m/s^2).
        max_yaw_accel: |alpha| limit (rad/s^2).
        max_vertical_accel: |a_z| limit (m/s^2).
        brake_decel: deceleration used when braking on stale input (m/s^2, rad/s^2 for yaw).
        max_speed: |vx| limit (m/s); max_reverse_speed: limit on backward speed (m/s).
        max_lateral_speed: |vy| limit (m/s, holonomic only).
        max_yaw_rate: |wz| limit (rad/s).
        max_vertical_speed: |vz| limit (m/s).
        min_height, max_height: body height range the gait controller can hold (m): the
            filter never asks to duck below min_height (it brakes or steers instead).
        height_gain: gain (1/s) of the height-range barrier on a_z.
        windup_band: largest lead of the command over the measured velocity (m/s, rad/s)
            beyond which integration in the leading direction stops (anti-windup).
        weights: QP weights on (a, alpha, a_z) or (a_x, a_y, a_z): a small weight makes the
            filter prefer changing that input (e.g. steer or duck rather than brake).
        odom_timeout, obstacles_timeout, reference_timeout: staleness limits (s, sim time).
        horizontal_y_margin: a bar counts only while the robot's y is within its extent plus
            half the robot width plus this margin (m).
        tie_break: each vertical obstacle's circle is shifted this far (m) to the robot's
            right and grown by as much, so that dead-ahead obstacles are passed on the left
            instead of only braked for (see ``obstacle_input.to_c3bf_obstacles``).
        deadlock_speed: the robot is deadlocked when the filter holds its commanded forward
            speed below this (m/s) while the reference asks for more (unicycle model).
        deadlock_yaw_rate: yaw rate (rad/s) the reference gets while deadlocked, to the side
            that passes the nearest obstacle on the tie-break side (0: never). At rest the
            barrier h is 0 and blind to steering, so only a turn in place lets the body point
            leave the collision cone; the QP still filters the turn.
        deadlock_turn_time: least duration (s) of a deadlock turn (ended early once the
            commanded speed exceeds twice ``deadlock_speed``).
        deadlock_memory: how long (s) the chosen side is kept after the last deadlocked cycle.
        max_future_stamp: how far (s) a stamp of /odom or /obstacles may be ahead of the
            node's clock (the clock's jitter between processes); later stamps are rejected
            and counted, never believed (a wall-clock stamp in a sim-time graph).
        max_obstacles: obstacles kept from one /obstacles message, nearest to the robot
            first; the rest are rejected and counted (bounded work on a flood).
        max_message_bytes: an /obstacles message larger than this (serialized bytes) is
            rejected before it is decoded (bounded work on a gigantic message).
        vanished_memory: how long (s) the cycle remembers an obstacle it saw; one that
            disappears from /obstacles within the robot's stopping distance (plus
            safety_margin) makes the cycle brake to a stop (EMERGENCY_BRAKE).

    """

    enabled: bool = True
    model: str = "unicycle"
    offset: float = 0.10
    gamma: float = 1.0
    robot_width: float = 0.82
    robot_height: float = 0.12
    safety_margin: float = 0.05
    rate: float = 50.0
    k_v: float = 2.0
    k_w: float = 3.0
    k_z: float = 3.0
    max_accel: float = 1.0
    max_yaw_accel: float = 4.0
    max_vertical_accel: float = 1.0
    brake_decel: float = 1.0
    max_speed: float = 0.8
    max_reverse_speed: float = 0.3
    max_lateral_speed: float = 0.3
    max_yaw_rate: float = 1.0
    max_vertical_speed: float = 0.2
    min_height: float = 0.20
    max_height: float = 0.285
    height_gain: float = 4.0
    windup_band: float = 0.3
    weights: tuple[float, float, float] = (1.0, 0.2, 0.5)
    odom_timeout: float = 0.2
    obstacles_timeout: float = 0.5
    reference_timeout: float = 0.5
    horizontal_y_margin: float = 0.1
    tie_break: float = 0.03
    deadlock_speed: float = 0.05
    deadlock_yaw_rate: float = 0.5
    deadlock_turn_time: float = 1.5
    deadlock_memory: float = 3.0
    max_future_stamp: float = 0.1
    max_obstacles: int = 32
    max_message_bytes: int = 262144
    vanished_memory: float = 1.0

    def validate(self) -> FilterParams:
        """Return self if valid, else raise ValueError naming the bad parameter."""
        if self.model not in MODELS:
            raise ValueError(f"model: must be one of {MODELS}, got {self.model!r}")
        positive = (
            "gamma", "robot_width", "robot_height", "rate", "k_v", "k_w", "k_z", "max_accel",
            "max_yaw_accel", "max_vertical_accel", "brake_decel", "max_speed",
            "max_lateral_speed", "max_yaw_rate", "max_vertical_speed", "height_gain",
            "windup_band", "odom_timeout", "obstacles_timeout", "reference_timeout",
            "vanished_memory",
        )
        non_negative = (
            "offset", "safety_margin", "max_reverse_speed", "horizontal_y_margin", "tie_break",
            "deadlock_speed", "deadlock_yaw_rate", "deadlock_turn_time", "deadlock_memory",
            "max_future_stamp",
        )
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
        for name in non_negative:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: must be a finite number >= 0, got {value!r}")
        for name in ("max_obstacles", "max_message_bytes"):
            value = getattr(self, name)
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise ValueError(f"{name}: must be an integer >= 1, got {value!r}")
        if not (0 < self.min_height < self.max_height):
            raise ValueError(
                f"min_height/max_height: need 0 < min_height < max_height, got "
                f"{self.min_height!r}, {self.max_height!r}"
            )
        if len(self.weights) != 3 or not all(math.isfinite(w) and w > 0 for w in self.weights):
            raise ValueError(f"weights: must be three finite numbers > 0, got {self.weights!r}")
        return self

    def updated(self, **changes: Any) -> FilterParams:
        """A validated copy with ``changes`` applied (raise ValueError on a bad value)."""
        known = {f.name for f in fields(self)}
        for name in changes:
            if name not in known:
                raise ValueError(f"{name}: unknown safety filter parameter")
        if "weights" in changes:
            changes["weights"] = tuple(float(w) for w in changes["weights"])
        return replace(self, **changes).validate()
