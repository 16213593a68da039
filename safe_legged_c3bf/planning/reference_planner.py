"""Reference (nominal) velocity planner for a legged robot.

The planner produces the *reference* command that the C3BF safety filter later modifies:
a body-frame twist ``(vx, vy, vz, yaw_rate)`` in ``base_link`` (REP-103: x forward, y left,
z up).  It never looks at obstacles.

Modes (:class:`PlannerMode`):

``goal``
    Unicycle-style go-to-goal.  The yaw rate is a saturated proportional law on the
    heading error towards the goal; the forward speed is ``min(max_vx, k_speed * d)``
    (linear slow-down near the goal) scaled down smoothly to zero as the heading error
    approaches ``heading_slowdown_angle`` (the robot turns in place when the goal is to the
    side or behind).  ``vy`` is always zero.  With ``k_speed < k_heading`` and
    ``k_speed < 2 max_yaw_rate`` the heading error always shrinks, so the robot cannot
    orbit the goal.
``holonomic``
    Drives straight towards the goal using ``vx`` and ``vy`` (no need to turn first):
    odom-frame velocity ``k_speed * (goal - position)`` rotated into the body frame and
    scaled down uniformly (direction preserved) to the body-frame limits.
``constant_velocity``
    Outputs the configured body-frame ``(vx, vy, yaw_rate)`` whatever the pose (the
    paper's experiments use constant target velocities).

In the goal modes, once the position is within ``goal_tolerance`` the planner turns to the
goal yaw if one was given, then reports ``arrived`` and outputs zero planar velocity.  It
stays stopped until the robot is pushed farther than ``resume_distance`` from the goal
(or, with a goal yaw, more than ``yaw_resume_tolerance`` off it): hysteresis, so that
noise around the tolerance does not make it creep.

The vertical channel holds a nominal body height in every mode:
``vz = clip(k_z (z_nominal - z), -max_vz, max_vz)`` (0 if the height is unknown).

Optional acceleration limits rate-limit every channel of the output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from numbers import Real

from safe_legged_c3bf.interfaces.rotations import wrap_angle
from safe_legged_c3bf.interfaces.typed_params import (
    FINITE,
    FLAG,
    NON_NEGATIVE,
    POSITIVE,
    TypedParams,
    interval,
    one_of,
    optional,
    param,
    vector,
)

__all__ = [
    "Goal",
    "PlannerConfig",
    "PlannerMode",
    "PlannerStatus",
    "ReferencePlanner",
    "RobotPose",
    "VelocityCommand",
    "validate_goal",
    "wrap_angle",
]


def _clip(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


class PlannerMode(StrEnum):
    """Operating mode of :class:`ReferencePlanner`."""

    GOAL = "goal"
    HOLONOMIC = "holonomic"
    CONSTANT_VELOCITY = "constant_velocity"


class PlannerStatus(StrEnum):
    """What the planner did in its last :meth:`ReferencePlanner.compute` call."""

    IDLE = "idle"  # goal mode without a goal: zero planar command
    DRIVING = "driving"  # moving towards the goal position
    ALIGNING = "aligning"  # at the goal position, turning to the goal yaw
    ARRIVED = "arrived"  # goal reached: zero planar command (with hysteresis)
    CONSTANT = "constant"  # constant-velocity mode
    INVALID_POSE = "invalid_pose"  # the pose was not finite: commanding a stop


@dataclass(frozen=True)
class Goal:
    """Goal in the odom frame: position (m) and optional final yaw (rad)."""

    x: float
    y: float
    yaw: float | None = None


@dataclass(frozen=True)
class RobotPose:
    """Robot base pose in the odom frame: position (m), yaw (rad), body height ``z`` (m).

    ``z`` may be ``None`` when the height is not known; the vertical command is then 0.
    """

    x: float
    y: float
    yaw: float
    z: float | None = None


@dataclass(frozen=True)
class VelocityCommand:
    """Body-frame (base_link) velocity command: m/s and rad/s."""

    vx: float = 0.0
    vy: float = 0.0
    vz: float = 0.0
    yaw_rate: float = 0.0

    def as_tuple(self) -> tuple[float, float, float, float]:
        """Return ``(vx, vy, vz, yaw_rate)``."""
        return (self.vx, self.vy, self.vz, self.yaw_rate)


def _is_number(value: object) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool)


def validate_goal(
    x: object,
    y: object,
    yaw: object = None,
    frame_id: str | None = None,
    expected_frame: str = "odom",
) -> tuple[Goal | None, str]:
    """Check a goal without raising.

    Returns ``(Goal, "")`` if the goal is usable, otherwise ``(None, reason)`` where
    ``reason`` says what is wrong (non-numeric or non-finite coordinate or yaw, or a frame
    other than ``expected_frame``).  ``frame_id=None`` skips the frame check; an empty
    string is a wrong frame.  ``yaw=None`` means "any final heading".
    """
    if frame_id is not None and frame_id != expected_frame:
        return None, f"goal frame '{frame_id}' is not '{expected_frame}'"
    values = {"x": x, "y": y} if yaw is None else {"x": x, "y": y, "yaw": yaw}
    for name, value in values.items():
        if not _is_number(value):
            return None, f"goal {name} is not a number: {value!r}"
        if not math.isfinite(float(value)):
            return None, f"goal {name} is not finite: {value!r}"
    return Goal(float(x), float(y), None if yaw is None else wrap_angle(float(yaw))), ""


@dataclass(frozen=True)
class PlannerConfig(TypedParams):
    """Parameters of :class:`ReferencePlanner` (SI units, validated at construction).

    Each field carries its unit and description. ``mode`` may be given as a string; it is
    stored as a :class:`PlannerMode`.
    """

    mode: PlannerMode | str = param(
        PlannerMode.GOAL, "-", "planner mode (a name): 'goal' (unicycle to the goal), "
        "'holonomic' (straight to the goal with vx and vy) or 'constant_velocity'",
        one_of(*(m.value for m in PlannerMode)),
    )
    max_vx: float = param(0.5, "m/s", "largest forward speed", POSITIVE)
    max_vx_backward: float = param(
        0.25, "m/s", "largest backward speed; holonomic mode only (the unicycle mode never "
        "reverses)", NON_NEGATIVE,
    )
    max_vy: float = param(
        0.3, "m/s", "largest lateral speed; holonomic and constant-velocity modes", POSITIVE
    )
    max_vz: float = param(0.2, "m/s", "largest vertical speed of the height hold", POSITIVE)
    max_yaw_rate: float = param(1.0, "rad/s", "largest yaw rate", POSITIVE)
    max_linear_accel: float | None = param(
        None, "m/s^2", "rate limit of vx, vy and vz; None disables rate limiting",
        optional(POSITIVE),
    )
    max_yaw_accel: float | None = param(
        None, "rad/s^2", "rate limit of the yaw rate; None disables it", optional(POSITIVE)
    )
    k_speed: float = param(
        0.8, "1/s", "speed gain: commanded speed k_speed * distance near the goal; in goal "
        "mode < k_heading and < 2 max_yaw_rate (otherwise the robot may orbit the goal)",
        POSITIVE,
    )
    k_heading: float = param(2.0, "1/s", "heading gain towards the goal (goal mode)", POSITIVE)
    k_yaw: float = param(
        1.5, "1/s", "gain of the final yaw alignment (and of the yaw in holonomic mode)",
        POSITIVE,
    )
    k_z: float = param(2.0, "1/s", "height gain", POSITIVE)
    z_nominal: float = param(
        0.30, "m", "body height held through the vertical command (odom z of base_link)",
        FINITE,
    )
    hold_height: bool = param(
        True, "-", "hold z_nominal (flag); false: the vertical command is always 0", FLAG
    )
    goal_tolerance: float = param(
        0.05, "m", "the goal position is reached within this distance", POSITIVE
    )
    resume_distance: float = param(
        0.15, "m", "after arriving, the planner moves again only beyond this distance; "
        "> goal_tolerance (hysteresis)", POSITIVE,
    )
    yaw_tolerance: float = param(
        0.05, "rad", "the goal yaw is reached within this error", POSITIVE
    )
    yaw_resume_tolerance: float = param(
        0.15, "rad", "after arriving, the planner turns again only beyond this yaw error; "
        "> yaw_tolerance (hysteresis)", POSITIVE,
    )
    heading_slowdown_angle: float = param(
        math.pi / 3, "rad", "goal mode: forward speed factor (cos e - cos a) / (1 - cos a) "
        "for heading error |e| < a, 0 beyond; pi/2 gives the classic cos e",
        interval(0.0, math.pi / 2, closed_high=True, high_text="pi/2"),
    )
    constant_velocity: tuple[float, float, float] = param(
        (0.0, 0.0, 0.0), "m/s, m/s, rad/s", "(vx, vy, yaw_rate) output in constant-velocity "
        "mode; must respect the limits", vector(3, FINITE),
    )
    control_period: float = param(
        0.02, "s", "nominal call period, used as time step by the rate limiter when no time "
        "is given to ReferencePlanner.compute (and on the first call)", POSITIVE,
    )

    def __post_init__(self) -> None:
        """Validate; raise ``ValueError`` whose message names the offending parameter."""
        self.validate()
        object.__setattr__(self, "mode", PlannerMode(self.mode))
        object.__setattr__(
            self, "constant_velocity", tuple(float(c) for c in self.constant_velocity)
        )

    def check_together(self) -> None:
        """Hysteresis, the goal mode's convergence conditions, constant velocity in limits."""
        if self.resume_distance <= self.goal_tolerance:
            raise ValueError("resume_distance: must be > goal_tolerance (hysteresis), got "
                             f"{self.resume_distance!r} <= {self.goal_tolerance!r}")
        if self.yaw_resume_tolerance <= self.yaw_tolerance:
            raise ValueError("yaw_resume_tolerance: must be > yaw_tolerance (hysteresis), got "
                             f"{self.yaw_resume_tolerance!r} <= {self.yaw_tolerance!r}")
        if PlannerMode(self.mode) is PlannerMode.GOAL:  # convergence of the unicycle law
            if self.k_speed >= self.k_heading:
                raise ValueError("k_heading: must be > k_speed (otherwise the robot may "
                                 f"orbit), got {self.k_heading!r} <= {self.k_speed!r}")
            if self.k_speed >= 2.0 * self.max_yaw_rate:
                raise ValueError("k_speed: must be < 2 * max_yaw_rate (otherwise it may "
                                 f"orbit), got {self.k_speed!r}, max_yaw_rate "
                                 f"{self.max_yaw_rate!r}")
        vx, vy, wz = (float(c) for c in self.constant_velocity)
        if not (-self.max_vx_backward <= vx <= self.max_vx and abs(vy) <= self.max_vy):
            raise ValueError("constant_velocity: exceeds max_vx/max_vx_backward/max_vy, got "
                             f"{self.constant_velocity!r}")
        if abs(wz) > self.max_yaw_rate:
            raise ValueError("constant_velocity: yaw rate exceeds max_yaw_rate, got "
                             f"{self.constant_velocity!r}")


class ReferencePlanner:
    """Reference velocity planner (see module docstring).

    Typical use::

        planner = ReferencePlanner(PlannerConfig(mode="goal"))
        ok, reason = planner.set_goal(3.0, 1.0, yaw=0.0, frame_id="odom")
        cmd = planner.compute(RobotPose(x, y, yaw, z), t)   # VelocityCommand in base_link

    """

    def __init__(self, config: PlannerConfig | None = None) -> None:
        self.config = config if config is not None else PlannerConfig()
        self._goal: Goal | None = None
        self._status = (
            PlannerStatus.CONSTANT
            if self.config.mode is PlannerMode.CONSTANT_VELOCITY
            else PlannerStatus.IDLE
        )
        self._position_reached = False
        self._yaw_reached = False
        self._last_cmd = VelocityCommand()
        self._last_time: float | None = None
        self.last_reason = ""

    # ------------------------------------------------------------------ goal handling
    @property
    def goal(self) -> Goal | None:
        """Current goal (``None`` if none)."""
        return self._goal

    @property
    def status(self) -> PlannerStatus:
        """Status after the last :meth:`compute` call."""
        return self._status

    @property
    def arrived(self) -> bool:
        """True while the goal is reached (and the planner holds still)."""
        return self._status is PlannerStatus.ARRIVED

    def set_goal(
        self, x: object, y: object, yaw: object = None, frame_id: str | None = None
    ) -> tuple[bool, str]:
        """Set a new goal; malformed goals are ignored (the previous goal stays).

        Returns ``(accepted, reason)``; ``reason`` is empty when accepted.
        """
        goal, reason = validate_goal(x, y, yaw, frame_id)
        if goal is None:
            self.last_reason = f"goal ignored: {reason}"
            return False, reason
        self._goal = goal
        self._position_reached = False
        self._yaw_reached = False
        self.last_reason = ""
        return True, ""

    def clear_goal(self) -> None:
        """Forget the goal (goal modes then output a zero planar command)."""
        self._goal = None
        self._position_reached = False
        self._yaw_reached = False

    def reset(self) -> None:
        """Forget the goal and the rate-limiter memory."""
        self.clear_goal()
        self._last_cmd = VelocityCommand()
        self._last_time = None

    # ------------------------------------------------------------------ control law
    def compute(self, pose: RobotPose, t: float | None = None) -> VelocityCommand:
        """Return the body-frame reference command for ``pose`` at time ``t`` (s).

        ``t`` only matters for the rate limiter; without it (and on the first call, or when
        the clock jumps backwards) ``control_period`` is used as the time step.  A
        non-finite pose yields a (rate-limited) stop.
        """
        cfg = self.config
        values = (pose.x, pose.y, pose.yaw)
        if not all(_is_number(v) and math.isfinite(float(v)) for v in values):
            self._status = PlannerStatus.INVALID_POSE
            self.last_reason = "pose is not finite"
            return self._rate_limit(VelocityCommand(), t)
        vz = self._height_command(pose.z)

        if cfg.mode is PlannerMode.CONSTANT_VELOCITY:
            vx, vy, wz = cfg.constant_velocity
            self._status = PlannerStatus.CONSTANT
            return self._rate_limit(VelocityCommand(vx, vy, vz, wz), t)
        if self._goal is None:
            self._status = PlannerStatus.IDLE
            return self._rate_limit(VelocityCommand(0.0, 0.0, vz, 0.0), t)

        goal = self._goal
        dx, dy = goal.x - float(pose.x), goal.y - float(pose.y)
        distance = math.hypot(dx, dy)
        yaw = float(pose.yaw)

        # Position hysteresis.
        if self._position_reached and distance > cfg.resume_distance:
            self._position_reached = False
            self._yaw_reached = False
        if not self._position_reached and distance <= cfg.goal_tolerance:
            self._position_reached = True
        # Yaw hysteresis (only once the position is reached).
        yaw_error = 0.0 if goal.yaw is None else wrap_angle(goal.yaw - yaw)
        if self._yaw_reached and abs(yaw_error) > cfg.yaw_resume_tolerance:
            self._yaw_reached = False
        if self._position_reached and not self._yaw_reached and abs(yaw_error) <= cfg.yaw_tolerance:
            self._yaw_reached = True

        if self._position_reached:
            if self._yaw_reached:
                self._status = PlannerStatus.ARRIVED
                return self._rate_limit(VelocityCommand(0.0, 0.0, vz, 0.0), t)
            self._status = PlannerStatus.ALIGNING
            wz = _clip(cfg.k_yaw * yaw_error, -cfg.max_yaw_rate, cfg.max_yaw_rate)
            return self._rate_limit(VelocityCommand(0.0, 0.0, vz, wz), t)

        self._status = PlannerStatus.DRIVING
        if cfg.mode is PlannerMode.HOLONOMIC:
            vx, vy = self._holonomic_velocity(dx, dy, yaw)
            wz = _clip(cfg.k_yaw * yaw_error, -cfg.max_yaw_rate, cfg.max_yaw_rate)
        else:
            heading_error = wrap_angle(math.atan2(dy, dx) - yaw)
            wz = _clip(cfg.k_heading * heading_error, -cfg.max_yaw_rate, cfg.max_yaw_rate)
            cos_limit = math.cos(cfg.heading_slowdown_angle)
            factor = max(0.0, (math.cos(heading_error) - cos_limit) / (1.0 - cos_limit))
            vx = min(cfg.max_vx, cfg.k_speed * distance) * factor
            vy = 0.0
        return self._rate_limit(VelocityCommand(vx, vy, vz, wz), t)

    def _holonomic_velocity(self, dx: float, dy: float, yaw: float) -> tuple[float, float]:
        cfg = self.config
        c, s = math.cos(yaw), math.sin(yaw)
        # Odom-frame proportional velocity, rotated into base_link.
        bx = cfg.k_speed * (c * dx + s * dy)
        by = cfg.k_speed * (-s * dx + c * dy)
        scale = 1.0
        if bx > cfg.max_vx:
            scale = min(scale, cfg.max_vx / bx)
        elif bx < -cfg.max_vx_backward:
            scale = min(scale, cfg.max_vx_backward / -bx)
        if abs(by) > cfg.max_vy:
            scale = min(scale, cfg.max_vy / abs(by))
        return bx * scale, by * scale

    def _height_command(self, z: float | None) -> float:
        cfg = self.config
        if not cfg.hold_height or z is None or not _is_number(z) or not math.isfinite(float(z)):
            return 0.0
        return _clip(cfg.k_z * (cfg.z_nominal - float(z)), -cfg.max_vz, cfg.max_vz)

    def _rate_limit(self, cmd: VelocityCommand, t: float | None) -> VelocityCommand:
        cfg = self.config
        now = None if t is None or not math.isfinite(float(t)) else float(t)
        if now is None or self._last_time is None or now < self._last_time:
            # No time, first call, or the clock jumped back (e.g. simulation restart).
            dt = cfg.control_period
        else:
            dt = now - self._last_time
        if now is not None:
            self._last_time = now
        prev = self._last_cmd
        out = cmd
        if cfg.max_linear_accel is not None:
            dv = cfg.max_linear_accel * dt
            out = VelocityCommand(
                _clip(out.vx, prev.vx - dv, prev.vx + dv),
                _clip(out.vy, prev.vy - dv, prev.vy + dv),
                _clip(out.vz, prev.vz - dv, prev.vz + dv),
                out.yaw_rate,
            )
        if cfg.max_yaw_accel is not None:
            dw = cfg.max_yaw_accel * dt
            out = VelocityCommand(
                out.vx, out.vy, out.vz, _clip(out.yaw_rate, prev.yaw_rate - dw, prev.yaw_rate + dw)
            )
        self._last_cmd = out
        return out
