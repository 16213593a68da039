"""Parameters of the safety filter node, with units, defaults and validation.

Every value is SI (m, s, rad); frames: odom for obstacles, base_link for commands. Each field
carries its unit, description and rule (:mod:`safe_legged_c3bf.interfaces.typed_params`);
``validate`` names the first bad parameter, so the node can reject a bad ``ros2 param set``
with the reason. Every parameter can be changed while the node runs.
"""

from __future__ import annotations

from dataclasses import dataclass

from safe_legged_c3bf.interfaces.typed_params import (
    FLAG,
    NON_NEGATIVE,
    POSITIVE,
    TypedParams,
    at_least,
    one_of,
    param,
    vector,
)

MODELS = ("unicycle", "unicycle_lateral", "holonomic")
#: Models whose yaw rate is a state (the filter turns the robot); the others side-step.
TURNING_MODELS = ("unicycle", "unicycle_lateral")
#: Models with a lateral (side-step) speed.
LATERAL_MODELS = ("unicycle_lateral", "holonomic")
BODY_MODELS = ("body", "point")
ROBOT_BODIES = ("a1", "biped")


@dataclass(frozen=True)
class FilterParams(TypedParams):
    """Safety filter parameters (see each field's description; floats refuse integers)."""

    int_for_float = False  # the node always typed its doubles strictly

    enabled: bool = param(
        True, "-", "false = pass-through (baseline runs), flagged PASS_THROUGH (flag)", FLAG
    )
    model: str = param(
        "unicycle", "-", "dynamics model: 'unicycle' (the paper's, with body-point offset "
        "'offset'), 'unicycle_lateral' (the unicycle with a side-step speed up to "
        "max_lateral_speed: the filter may also step aside) or 'holonomic' (unitless)",
        one_of(*MODELS),
    )
    body_model: str = param(
        "point", "-", "'body': every (body point, obstacle) pair of the robot's cover "
        "(robot_body) is a constraint, the obstacles grown by safety_margin and each point's "
        "radius (robot_width, robot_height and offset unused); 'point': the paper's single "
        "body point 'offset' ahead with circles grown by robot_width/2 and robot_height/2",
        one_of(*BODY_MODELS),
    )
    robot_body: str = param(
        "a1", "-", "the robot whose cover (c3bf.body) the 'body' model uses", one_of(*ROBOT_BODIES)
    )
    offset: float = param(
        0.10, "m", "body-point offset l ahead of the robot's centre, unicycle only: larger "
        "gives more steering authority but a larger circle to enclose the robot", NON_NEGATIVE,
    )
    gamma: float = param(
        1.0, "1/s", "class-K gain in Lf h + Lg h u + gamma h >= 0; the paper uses 1", POSITIVE
    )
    robot_width: float = param(
        0.82, "m", "w in the paper's r = max(c1, c2) + w/2: the diameter of the circle around "
        "the body point that encloses the robot's footprint (legs included). For a long robot "
        "this is its circumscribed diameter, not its narrow width: a circle of half the width "
        "would leave the rear exposed to crossing obstacles", POSITIVE,
    )
    robot_height: float = param(
        0.12, "m", "robot body height; horizontal obstacles grow by robot_height/2", POSITIVE
    )
    safety_margin: float = param(
        0.05, "m", "extra inflation of every obstacle radius", NON_NEGATIVE
    )
    exit_speed: float = param(
        0.05, "m/s", "radial speed at which a robot found inside an obstacle's inflated circle "
        "is made to leave it (at least, asymptotically; 0: only never deeper)", NON_NEGATIVE,
    )
    rate: float = param(50.0, "Hz", "filter cycles per second of sim time", POSITIVE)
    k_v: float = param(2.0, "1/s", "reference tracking gain on speed: u_ref = k (v_ref - v)",
                       POSITIVE)
    k_w: float = param(3.0, "1/s", "reference tracking gain on yaw rate", POSITIVE)
    k_z: float = param(3.0, "1/s", "reference tracking gain on vertical speed", POSITIVE)
    max_accel: float = param(
        1.0, "m/s^2", "|a| limit on forward/lateral acceleration", POSITIVE
    )
    max_yaw_accel: float = param(4.0, "rad/s^2", "yaw acceleration limit |alpha|", POSITIVE)
    max_vertical_accel: float = param(1.0, "m/s^2", "vertical acceleration limit |a_z|", POSITIVE)
    brake_decel: float = param(
        1.0, "m/s^2", "deceleration used when braking on stale input (rad/s^2 for yaw)",
        POSITIVE,
    )
    max_speed: float = param(0.8, "m/s", "forward speed limit |vx|", POSITIVE)
    max_speedup: float = param(
        0.1, "m/s", "whole-body model: how far above the reference's forward speed the filter "
        "may command (the collision cone is then left by turning or braking; the paper's "
        "filter may run up to max_speed past an obstacle)", NON_NEGATIVE,
    )
    max_reverse_speed: float = param(0.3, "m/s", "limit on backward speed", NON_NEGATIVE)
    max_lateral_speed: float = param(
        0.3, "m/s", "lateral speed limit |vy| (unicycle_lateral and holonomic)", POSITIVE
    )
    max_yaw_rate: float = param(1.0, "rad/s", "yaw rate limit |wz|", POSITIVE)
    max_vertical_speed: float = param(0.2, "m/s", "vertical speed limit |vz|", POSITIVE)
    min_height: float = param(
        0.20, "m", "lowest body height the gait controller can hold: the filter never asks to "
        "duck below it (it brakes or steers instead); < max_height", POSITIVE,
    )
    max_height: float = param(
        0.285, "m", "highest body height the gait controller can hold; > min_height", POSITIVE
    )
    height_gain: float = param(4.0, "1/s", "gain of the height-range barrier on a_z", POSITIVE)
    windup_band: float = param(
        0.3, "m/s", "largest lead of the command over the measured velocity (rad/s for yaw) "
        "beyond which integration in the leading direction stops (anti-windup)", POSITIVE,
    )
    windup_window: float = param(
        0.0, "s", "the anti-windup compares the command with the measured velocity averaged "
        "over this window (a walking gait's velocity swings within each step: one gait "
        "cycle averages the sway out); 0: the latest measurement", NON_NEGATIVE,
    )
    weights: tuple[float, float, float] = param(
        (1.0, 0.2, 0.5), "-", "unitless QP weights on (a, alpha, a_z) or (a_x, a_y, a_z): a "
        "small weight makes the filter prefer changing that input (e.g. steer or duck rather "
        "than brake)", vector(3, POSITIVE),
    )
    lateral_weight: float = param(
        1.0, "-", "unitless QP weight on the lateral acceleration a_l (unicycle_lateral only; "
        "the weights above keep theirs)", POSITIVE,
    )
    odom_timeout: float = param(0.2, "s", "staleness limit of /odom (sim time)", POSITIVE)
    obstacles_timeout: float = param(
        0.5, "s", "staleness limit of /obstacles (sim time)", POSITIVE
    )
    reference_timeout: float = param(
        0.5, "s", "staleness limit of /cmd_vel (sim time)", POSITIVE
    )
    horizontal_y_margin: float = param(
        0.1, "m", "a bar counts only while the robot's y is within its extent plus half the "
        "robot width plus this margin", NON_NEGATIVE,
    )
    tie_break: float = param(
        0.03, "m", "each vertical obstacle's circle is shifted this far to the robot's right "
        "and grown by as much, so that dead-ahead obstacles are passed on the left instead of "
        "only braked for (see obstacle_input.to_c3bf_obstacles)", NON_NEGATIVE,
    )
    tie_break_speed: float = param(
        0.0, "m/s", "whole body with cone steering (which picks the side of static obstacles) "
        "only: an obstacle gets the tie-break in proportion to its speed, in full from this "
        "speed on, a margin for movers (whose velocity the tracker learns late) and not a "
        "narrowing of doorways between static obstacles; 0: every obstacle in full",
        NON_NEGATIVE,
    )
    bar_wall_range: float = param(
        0.0, "m", "a bar is judged passable or not (and walled if not, safety/bar_walls.py) "
        "only while the base is within this horizontal distance of its footprint; farther "
        "it stays a bar the x-z barrier keeps the body from. A range sensor's bar height is "
        "least certain far away (the obstacle detector's underside errs low by up to one row "
        "of the 3-D sensor: 2 cm per metre); 0: at any distance (the oracle's noise does not "
        "grow with it)", NON_NEGATIVE,
    )
    steer_horizon: float = param(
        20.0, "s", "cone steering (whole-body model, unicycle): a reference heading whose path "
        "meets an obstacle within this time is turned to the nearest free heading before the QP "
        "(safety/cone_steering.py); 0: off. The C3BF itself is distance-free (it refuses to "
        "enter a cone at any distance), so a short horizon leaves far cones to the QP, which "
        "brakes", NON_NEGATIVE,
    )
    escape_horizon: float = param(
        6.0, "s", "escape shaping (whole-body model): when the robot's cover, standing still, "
        "would meet a moving obstacle within this time and the reference's own path is not "
        "clear either, the reference becomes the nearest body-frame velocity within the speed "
        "limits whose path stays clear over it (none: the latest contact, moving no body point "
        "towards a mover), tracked at full acceleration; heading held for the side-stepping "
        "models (safety/escape.py), a turn first for the plain unicycle "
        "(safety/turning_escape.py); 0: off", NON_NEGATIVE,
    )
    steer_lookahead: float = param(
        0.5, "s", "cone steering: the reference heading is yaw + reference yaw rate times "
        "this (the planner's 1 / k_heading)", NON_NEGATIVE,
    )
    steer_gain: float = param(
        1.5, "1/s", "cone steering: yaw rate per radian between the free heading and the yaw",
        POSITIVE,
    )
    steer_cruise_memory: float = param(
        30.0, "s", "cone steering: a steered reference that asks to walk forward gets at least "
        "the largest forward speed the reference asked for in this window (the planner's "
        "cruise speed; a goal-seeking planner slows with the heading error the steering "
        "holds); 0: the reference's own speed", NON_NEGATIVE,
    )
    steer_min_free_run: int = param(
        1, "-", "cone steering and stall detour: the fewest free 5 deg grid headings a run "
        "must hold to be turned to; a shorter one (a narrow window between two cones) is "
        "passed over for the next. 1: every run, a short one aimed at its middle (the A1 "
        "threads quadruped_gap's doorway that way); the biped, whose heading drifts 6 times "
        "as far (doc/evaluation.md, velocity tracking), stood in such windows",
        at_least(1),
    )
    steer_settle_yaw_rate: float = param(
        0.0, "rad/s", "cone steering from rest: a robot turned in place to a free heading walks "
        "off only once its commanded yaw rate is below this, straight along the heading (a "
        "turn that goes on sweeps the offset body points' velocities across the cone and the "
        "QP creeps); 0: off, it walks off turning back towards the cone's edge",
        NON_NEGATIVE,
    )
    deadlock_speed: float = param(
        0.05, "m/s", "the robot is deadlocked when the filter holds its commanded forward "
        "speed below this while the reference asks for more (unicycle model)", NON_NEGATIVE,
    )
    deadlock_yaw_rate: float = param(
        0.5, "rad/s", "yaw rate the reference gets while deadlocked, to the side that passes "
        "the nearest obstacle on the tie-break side (0: never). At rest the barrier h is 0 "
        "and blind to steering, so only a turn in place lets the body point leave the "
        "collision cone; the QP still filters the turn", NON_NEGATIVE,
    )
    deadlock_turn_time: float = param(
        1.5, "s", "least duration of a deadlock turn (ended early once the commanded speed "
        "exceeds twice deadlock_speed)", NON_NEGATIVE,
    )
    deadlock_memory: float = param(
        3.0, "s", "how long the chosen side is kept after the last deadlocked cycle",
        NON_NEGATIVE,
    )
    max_future_stamp: float = param(
        0.1, "s", "how far a stamp of /odom or /obstacles may be ahead of the node's clock "
        "(the clock's jitter between processes); later stamps are rejected and counted, never "
        "believed (a wall-clock stamp in a sim-time graph)", NON_NEGATIVE,
    )
    max_obstacles: int = param(
        32, "-", "obstacles (a count) kept from one /obstacles message, nearest to the robot "
        "first; the rest are rejected and counted (bounded work on a flood)", at_least(1),
    )
    max_message_bytes: int = param(
        262144, "bytes", "an /obstacles message larger than this (serialized) is rejected "
        "before it is decoded (bounded work on a gigantic message)", at_least(1),
    )
    vanished_memory: float = param(
        1.0, "s", "how long the cycle remembers an obstacle it saw; one that disappears from "
        "/obstacles within the robot's stopping distance (plus safety_margin) makes the cycle "
        "brake to a stop (EMERGENCY_BRAKE)", POSITIVE,
    )

    def check_together(self) -> None:
        """The height range must be ordered: 0 < min_height < max_height."""
        if not self.min_height < self.max_height:
            raise ValueError(
                f"min_height/max_height: need 0 < min_height < max_height, got "
                f"{self.min_height!r}, {self.max_height!r}"
            )
