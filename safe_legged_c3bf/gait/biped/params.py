"""Validated parameters of the biped ZMP gait controller.

Grouped dataclasses, all SI units (m, s, rad, N m). ``BipedParams.from_yaml`` reads
``config/biped_controller.yaml``, which is in ROS 2 parameter-file form
(``/**: ros__parameters: {...}``) so the node wrapper can load the same file; nested keys map
to dotted ROS parameter names (``gait.step_height``), see :meth:`BipedParams.from_flat`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

LEG_JOINT_KEYS = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")


def _check(condition: bool, message: str) -> None:
    if not condition:
        raise ValueError(message)


@dataclass(frozen=True)
class GaitParams:
    """Timing and geometry of the walk.

    Attributes:
        control_period: controller tick (s); also the preview model's sample time.
        com_height: constant CoM height above the soles (m), the LIPM's z_c.
        single_support: single-support (swing) duration (s).
        double_support: double-support duration between steps (s).
        start_delay: time the ZMP reference stays put after a walk is commanded, so the
            preview controller can prepare the first weight shift (s).
        start_double_support: weight-shift duration before the first step (s).
        stop_double_support: duration of the final shift back to both feet (s).
        touchdown_blend: time over which a landed leg's gains ramp from swing to stance (s).
        liftoff_blend: time before lift-off over which the gains ramp back to swing (s).
        step_height: swing foot apex height (m).
        step_width: nominal lateral distance between the feet (m).
        zmp_offset_x: ZMP reference ahead of the ankle, in the foot frame (m).
        zmp_inward: ZMP reference shifted towards the other foot (m).
        swing_lift_fraction: swing fraction before the foot starts moving horizontally.
        swing_land_fraction: swing fraction at which the horizontal motion ends.
        replan_until: swing fraction after which the swing target is frozen.
        preview_horizon: ZMP preview time (s).
        preview_q_e: preview weight on the ZMP error.
        preview_r: preview weight on the jerk increment.

    """

    control_period: float = 0.005
    com_height: float = 0.60
    single_support: float = 0.40
    double_support: float = 0.12
    start_delay: float = 0.25
    start_double_support: float = 0.30
    stop_double_support: float = 0.40
    touchdown_blend: float = 0.05
    liftoff_blend: float = 0.04
    step_height: float = 0.05
    step_width: float = 0.20
    zmp_offset_x: float = 0.02
    zmp_inward: float = 0.0
    swing_lift_fraction: float = 0.10
    swing_land_fraction: float = 0.85
    replan_until: float = 0.60
    preview_horizon: float = 1.6
    preview_q_e: float = 1.0
    preview_r: float = 1e-6

    def validate(self) -> None:
        """Raise ValueError on inconsistent values."""
        _check(0.0005 <= self.control_period <= 0.02, "control_period must be in [0.5, 20] ms")
        _check(0.3 <= self.com_height <= 0.75, "com_height must be in [0.3, 0.75] m")
        _check(self.single_support >= 0.2, "single_support must be >= 0.2 s")
        _check(self.double_support >= 2 * self.control_period, "double_support too short")
        _check(self.start_double_support >= self.double_support, "start_double_support too short")
        _check(0.0 <= self.start_delay <= 2.0, "start_delay must be in [0, 2] s")
        _check(self.stop_double_support >= self.double_support, "stop_double_support too short")
        _check(0.0 < self.step_height <= 0.15, "step_height must be in (0, 0.15] m")
        _check(
            0.0 < self.touchdown_blend <= self.double_support + self.single_support / 2
            and 0.0 < self.liftoff_blend <= self.double_support,
            "gain blend times must be positive and fit in the double support",
        )
        _check(0.12 <= self.step_width <= 0.35, "step_width must be in [0.12, 0.35] m")
        _check(abs(self.zmp_offset_x) <= 0.05 and 0 <= self.zmp_inward <= 0.04, "zmp offsets")
        _check(
            0.0 <= self.swing_lift_fraction < self.swing_land_fraction <= 1.0,
            "need 0 <= swing_lift_fraction < swing_land_fraction <= 1",
        )
        _check(0.0 <= self.replan_until <= self.swing_land_fraction, "replan_until out of range")
        _check(self.preview_horizon >= 0.5, "preview_horizon must be >= 0.5 s")
        _check(self.preview_q_e > 0 and self.preview_r > 0, "preview weights must be > 0")

    @property
    def step_period(self) -> float:
        """Duration of one step (double + single support) (s)."""
        return self.single_support + self.double_support


@dataclass(frozen=True)
class StepLimits:
    """Reachable footstep region, relative to the support foot's frame.

    Attributes:
        max_forward: largest forward displacement of the new foot (m).
        max_backward: largest backward displacement (m).
        min_width: smallest lateral distance between the feet (m).
        max_width: largest lateral distance between the feet (m).
        max_yaw: largest relative yaw between consecutive footprints (rad).
        max_inward_yaw: largest relative yaw turning the toes towards the other foot (rad).

    """

    max_forward: float = 0.16
    max_backward: float = 0.10
    min_width: float = 0.16
    max_width: float = 0.30
    max_yaw: float = 0.30
    max_inward_yaw: float = 0.25

    def validate(self) -> None:
        """Raise ValueError on inconsistent values."""
        _check(0 < self.max_forward <= 0.3 and 0 <= self.max_backward <= 0.2, "step lengths")
        _check(0.12 <= self.min_width < self.max_width <= 0.4, "step widths")
        _check(0 < self.max_inward_yaw <= self.max_yaw <= 0.6, "step yaw limits")


@dataclass(frozen=True)
class CommandLimits:
    """Accepted velocity command range and its rate limits.

    Attributes:
        vx_min: lowest forward speed (m/s, negative = backwards).
        vx_max: highest forward speed (m/s).
        vy_max: highest sideways speed magnitude (m/s).
        yaw_rate_max: highest turning rate magnitude (rad/s).
        accel_x: forward acceleration limit of the internal command (m/s^2).
        accel_y: sideways acceleration limit (m/s^2).
        accel_yaw: yaw acceleration limit (rad/s^2).
        start_threshold: a standing robot starts walking once a commanded component exceeds
            this (m/s or rad/s); smaller commands (solver noise) leave it standing.
        stop_threshold: a walking robot stops once every component of the command and of the
            rate-limited command is below this (m/s or rad/s); the stop is then finished (the
            feet side by side, standing) before a new command starts a walk.

    """

    vx_min: float = -0.10
    vx_max: float = 0.20
    vy_max: float = 0.08
    yaw_rate_max: float = 0.40
    accel_x: float = 0.3
    accel_y: float = 0.2
    accel_yaw: float = 0.8
    start_threshold: float = 0.005
    stop_threshold: float = 0.001

    def validate(self) -> None:
        """Raise ValueError on inconsistent values."""
        _check(
            0.0 < self.stop_threshold <= self.start_threshold <= 0.05,
            "need 0 < stop_threshold <= start_threshold <= 0.05",
        )
        _check(self.vx_min <= 0.0 < self.vx_max, "need vx_min <= 0 < vx_max")
        _check(self.vy_max >= 0 and self.yaw_rate_max >= 0, "vy_max, yaw_rate_max must be >= 0")
        _check(min(self.accel_x, self.accel_y, self.accel_yaw) > 0, "accelerations must be > 0")

    def clip(self, vx: float, vy: float, yaw_rate: float) -> np.ndarray:
        """Return (vx, vy, yaw_rate) clipped to the limits; non-finite values become 0."""
        out = []
        for value, lo, hi in (
            (vx, self.vx_min, self.vx_max),
            (vy, -self.vy_max, self.vy_max),
            (yaw_rate, -self.yaw_rate_max, self.yaw_rate_max),
        ):
            value = float(value)
            out.append(min(max(value, lo), hi) if math.isfinite(value) else 0.0)
        return np.array(out)


@dataclass(frozen=True)
class FeedbackGains:
    """Gains of the balance feedback on top of the preview walk.

    Attributes:
        dcm_gain: convergence rate of the DCM (capture point) error (1/s): the desired ZMP is
            the preview ZMP plus (1 + dcm_gain / omega) times the DCM error (ankle strategy).
        step_adjust_gain: fraction of the DCM error predicted at touchdown added to the swing
            foot target (stepping strategy).
        max_step_adjust: bound on that footstep correction (m).
        support_margin: the desired ZMP is kept this far inside the sole edges (m).
        torso_pitch_gain: stance-hip pitch offset per rad of measured torso pitch.
        torso_roll_gain: stance-hip roll offset per rad of measured torso roll.
        torso_yaw_gain: stance-hip yaw offset per rad of torso heading error.
        reference_reset: at touchdown, when the measured DCM is farther than this from the
            preview model's (m), the model restarts from the measured CoM state (0: never).
        com_velocity_filter: low-pass time constant of the measured CoM velocity (s).
        tilt_filter: low-pass time constant of the torso tilt used for the swing leg (s).
        swing_anchor_filter: low-pass time constant of the pelvis position the swing leg is
            solved from (s); the filter predicts with the measured CoM velocity, so it has no lag
            in steady motion.

    """

    dcm_gain: float = 3.0
    step_adjust_gain: float = 1.0
    max_step_adjust: float = 0.08
    support_margin: float = 0.02
    torso_pitch_gain: float = 2.0
    torso_roll_gain: float = 2.0
    torso_yaw_gain: float = 1.0
    reference_reset: float = 0.03
    com_velocity_filter: float = 0.02
    tilt_filter: float = 0.05
    swing_anchor_filter: float = 0.05

    def validate(self) -> None:
        """Raise ValueError on inconsistent values."""
        _check(0 <= self.dcm_gain <= 20, "dcm_gain must be in [0, 20] 1/s")
        _check(0 <= self.step_adjust_gain <= 2 and 0 <= self.max_step_adjust <= 0.2, "stepping")
        _check(0 <= self.support_margin < 0.05, "support_margin must be in [0, 0.05) m")
        _check(
            0 <= self.torso_pitch_gain <= 4
            and 0 <= self.torso_roll_gain <= 4
            and 0 <= self.torso_yaw_gain <= 4,
            "torso gains must be in [0, 4]",
        )
        _check(0 <= self.reference_reset <= 1.0, "reference_reset must be in [0, 1] m")
        _check(0 <= self.com_velocity_filter <= 0.2, "com_velocity_filter must be in [0, 0.2] s")
        _check(0 <= self.tilt_filter <= 1.0, "tilt_filter must be in [0, 1] s")
        _check(0 <= self.swing_anchor_filter <= 1.0, "swing_anchor_filter must be in [0, 1] s")


def _default_kp() -> dict[str, float]:
    return {
        "hip_yaw": 400.0,
        "hip_roll": 600.0,
        "hip_pitch": 600.0,
        "knee": 600.0,
        "ankle_pitch": 60.0,
        "ankle_roll": 60.0,
    }


def _default_kd() -> dict[str, float]:
    return {
        "hip_yaw": 4.0,
        "hip_roll": 8.0,
        "hip_pitch": 8.0,
        "knee": 8.0,
        "ankle_pitch": 3.0,
        "ankle_roll": 2.0,
    }


def _default_swing_kp() -> dict[str, float]:
    return {
        "hip_yaw": 400.0,
        "hip_roll": 900.0,
        "hip_pitch": 900.0,
        "knee": 900.0,
        "ankle_pitch": 100.0,
        "ankle_roll": 60.0,
    }


def _default_swing_kd() -> dict[str, float]:
    return {
        "hip_yaw": 4.0,
        "hip_roll": 12.0,
        "hip_pitch": 12.0,
        "knee": 12.0,
        "ankle_pitch": 1.5,
        "ankle_roll": 0.8,
    }


@dataclass(frozen=True)
class JointGains:
    """Motor PD gains per leg joint, for stance and swing legs.

    Attributes:
        stance_kp: joint key -> position gain of a supporting leg (N m / rad).
        stance_kd: joint key -> velocity gain of a supporting leg (N m s / rad).
        swing_kp: the same for a swinging leg.
        swing_kd: the same for a swinging leg.
        feedforward: scale of all feed-forward torques (leg weights, ground reaction, inertia).
        inertia_feedforward: scale of the swing leg's inertia x acceleration feed-forward.

    """

    stance_kp: dict[str, float] = field(default_factory=_default_kp)
    stance_kd: dict[str, float] = field(default_factory=_default_kd)
    swing_kp: dict[str, float] = field(default_factory=_default_swing_kp)
    swing_kd: dict[str, float] = field(default_factory=_default_swing_kd)
    feedforward: float = 1.0
    inertia_feedforward: float = 1.0

    def validate(self) -> None:
        """Raise ValueError on inconsistent values."""
        for name in ("stance_kp", "stance_kd", "swing_kp", "swing_kd"):
            table = getattr(self, name)
            _check(set(table) == set(LEG_JOINT_KEYS), f"{name} needs keys {LEG_JOINT_KEYS}")
            _check(all(math.isfinite(v) and v >= 0 for v in table.values()), f"{name} must be >= 0")
        _check(0.0 <= self.feedforward <= 1.5, "feedforward scale must be in [0, 1.5]")
        _check(0.0 <= self.inertia_feedforward <= 1.5, "inertia_feedforward must be in [0, 1.5]")

    def leg_array(self, table: str) -> np.ndarray:
        """(6,) gains of one leg in joint order, from the table named ``table``."""
        values = getattr(self, table)
        return np.array([values[k] for k in LEG_JOINT_KEYS], dtype=float)


@dataclass(frozen=True)
class BipedParams:
    """All parameters of :class:`safe_legged_c3bf.gait.biped.controller.BipedZmpController`."""

    gait: GaitParams = field(default_factory=GaitParams)
    steps: StepLimits = field(default_factory=StepLimits)
    command: CommandLimits = field(default_factory=CommandLimits)
    feedback: FeedbackGains = field(default_factory=FeedbackGains)
    gains: JointGains = field(default_factory=JointGains)

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Validate every group, plus the cross-group constraints."""
        for group in (self.gait, self.steps, self.command, self.feedback, self.gains):
            group.validate()
        _check(
            self.steps.min_width <= self.gait.step_width <= self.steps.max_width,
            "gait.step_width must lie within [steps.min_width, steps.max_width]",
        )
        period = self.gait.step_period
        _check(
            self.command.vx_max * period <= self.steps.max_forward + 1e-9
            and -self.command.vx_min * period <= self.steps.max_backward + 1e-9,
            "command.vx limits exceed the step length limits at this step period",
        )
        _check(
            self.command.yaw_rate_max * period <= self.steps.max_inward_yaw + 1e-9,
            "command.yaw_rate_max exceeds the per-step yaw limit",
        )

    @classmethod
    def from_dict(cls, data: dict) -> BipedParams:
        """Build from a nested dict ``{group: {field: value}}``; unknown keys are errors."""
        kwargs = {}
        groups = {f.name: f for f in dataclasses.fields(cls)}
        for key, value in (data or {}).items():
            if key not in groups:
                raise ValueError(f"unknown biped parameter group '{key}'")
            group_cls = groups[key].default_factory
            known = {f.name for f in dataclasses.fields(group_cls)}
            unknown = set(value) - known
            if unknown:
                raise ValueError(f"unknown parameters {sorted(unknown)} in group '{key}'")
            if group_cls is JointGains:
                defaults = JointGains()
                value = {
                    k: ({**getattr(defaults, k), **v} if isinstance(v, dict) else v)
                    for k, v in value.items()
                }
            kwargs[key] = group_cls(**value)
        return cls(**kwargs)

    @classmethod
    def from_flat(cls, flat: dict[str, object]) -> BipedParams:
        """Build from dotted names as ROS parameters give them (``gait.step_height``: 0.05).

        A leading ``biped.`` (the namespace used in ``config/biped_controller.yaml``) is
        stripped.
        """
        nested: dict = {}
        for name, value in flat.items():
            node = nested
            parts = name.split(".")
            if parts[0] == "biped" and len(parts) > 2:
                parts = parts[1:]
            for part in parts[:-1]:
                node = node.setdefault(part, {})
            node[parts[-1]] = value
        return cls.from_dict(nested)

    @classmethod
    def from_yaml(cls, path: str) -> BipedParams:
        """Read a YAML file, plain or in ROS 2 form (``<node>: ros__parameters: ...``).

        A relative path that does not exist is looked up in the package's config directory.
        """
        from safe_legged_c3bf.run.config import load_yaml

        data = load_yaml(path)
        if len(data) == 1:
            (only,) = data.values()
            if isinstance(only, dict) and "ros__parameters" in only:
                data = only["ros__parameters"]
        if "ros__parameters" in data:
            data = data["ros__parameters"]
        return cls.from_dict(data.get("biped", data))

    def to_dict(self) -> dict:
        """Nested dict of all parameters (inverse of :meth:`from_dict`)."""
        return dataclasses.asdict(self)
