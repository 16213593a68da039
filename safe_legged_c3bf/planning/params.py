"""The reference planner node's parameters (no ROS); ``config/reference_planner.yaml``.

:class:`ReferencePlannerParams` is what the node declares: its own parameters (rate, goal,
scenario...) and the planner's, whose unit, description and rule come from
:class:`~safe_legged_c3bf.planning.reference_planner.PlannerConfig`. Two differ from the
PlannerConfig fields they set: the acceleration limits are 0 for "none" (a parameter cannot
be None) and ``constant_vx``/``constant_vy``/``constant_yaw_rate`` make up
``constant_velocity``. :meth:`ReferencePlannerParams.planner_config` builds the PlannerConfig.
``scenario`` and ``diagnostics_period`` are fixed at start-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from safe_legged_c3bf.interfaces.typed_params import (
    FINITE,
    FINITE_OR_NAN,
    NON_NEGATIVE,
    POSITIVE,
    TEXT,
    TypedParams,
    param,
    param_like,
)
from safe_legged_c3bf.planning.reference_planner import PlannerConfig

#: Body height (m, odom z of base_link) the reference planner holds, per robot kind.
NOMINAL_HEIGHT = {"quadruped": 0.28, "biped": 0.82}
#: The parameters that set a goal when they are set.
GOAL_PARAMS = ("goal_x", "goal_y", "goal_yaw")


def _like(name: str, *default: object) -> object:
    """A parameter like PlannerConfig's field ``name`` (with another default if given)."""
    return param_like(PlannerConfig, name, *default)


@dataclass(frozen=True)
class ReferencePlannerParams(TypedParams):
    """Reference planner node parameters (an integer is accepted for a float)."""

    rate: float = param(
        50.0, "Hz", "publish rate of /cmd_vel (sim time); also the planner's time step",
        POSITIVE,
    )
    odom_timeout: float = param(
        0.5, "s", "odometry older than this (sim time) -> zero command", POSITIVE
    )
    diagnostics_period: float = param(
        1.0, "s", "period of /diagnostics (sim time)", POSITIVE, fixed=True
    )
    scenario: str = param(
        "", "-", "scenario name or path whose goal and planner section to use; '' = none "
        "(a name, unitless)", TEXT, fixed=True,
    )
    goal_x: float = param(math.nan, "m", "goal x in odom; NaN = none", FINITE_OR_NAN)
    goal_y: float = param(math.nan, "m", "goal y in odom; NaN = none", FINITE_OR_NAN)
    goal_yaw: float = param(
        math.nan, "rad", "final heading at the goal; NaN = any", FINITE_OR_NAN
    )
    mode: str = _like("mode", "goal")
    constant_vx: float = param(0.0, "m/s", "constant_velocity mode: forward speed", FINITE)
    constant_vy: float = param(0.0, "m/s", "constant_velocity mode: lateral speed", FINITE)
    constant_vz: float = param(
        0.0, "m/s", "constant_velocity mode: vertical speed; 0 = hold z_nominal; "
        "|constant_vz| <= max_vz", FINITE,
    )
    constant_yaw_rate: float = param(
        0.0, "rad/s", "constant_velocity mode: yaw rate", FINITE
    )
    max_vx: float = _like("max_vx")
    max_vx_backward: float = _like("max_vx_backward")
    max_vy: float = _like("max_vy")
    max_vz: float = _like("max_vz")
    max_yaw_rate: float = _like("max_yaw_rate")
    max_linear_accel: float = param(
        0.0, "m/s^2", "rate limit of vx, vy, vz; 0 = none", NON_NEGATIVE
    )
    max_yaw_accel: float = param(
        0.0, "rad/s^2", "rate limit of the yaw rate; 0 = none", NON_NEGATIVE
    )
    k_speed: float = _like("k_speed")
    k_heading: float = _like("k_heading")
    k_yaw: float = _like("k_yaw")
    k_z: float = _like("k_z")
    z_nominal: float = _like("z_nominal", NOMINAL_HEIGHT["quadruped"])
    hold_height: bool = _like("hold_height")
    goal_tolerance: float = _like("goal_tolerance")
    resume_distance: float = _like("resume_distance")
    yaw_tolerance: float = _like("yaw_tolerance")
    yaw_resume_tolerance: float = _like("yaw_resume_tolerance")
    heading_slowdown_angle: float = _like("heading_slowdown_angle")

    def planner_config(self) -> PlannerConfig:
        """The planner's configuration (raises ValueError naming a bad parameter)."""
        same = (
            "mode", "max_vx", "max_vx_backward", "max_vy", "max_vz", "max_yaw_rate", "k_speed",
            "k_heading", "k_yaw", "k_z", "z_nominal", "hold_height", "goal_tolerance",
            "resume_distance", "yaw_tolerance", "yaw_resume_tolerance", "heading_slowdown_angle",
        )
        return PlannerConfig(
            **{name: getattr(self, name) for name in same},
            max_linear_accel=self.max_linear_accel or None,  # 0 = no limit
            max_yaw_accel=self.max_yaw_accel or None,
            constant_velocity=(self.constant_vx, self.constant_vy, self.constant_yaw_rate),
            control_period=1.0 / float(self.rate),
        )

    def check_together(self) -> None:
        """The planner's own rules (PlannerConfig), and |constant_vz| <= max_vz."""
        self.planner_config()
        if abs(float(self.constant_vz)) > self.max_vz:
            raise ValueError(
                f"constant_vz: must be within +-max_vz ({self.max_vz!r}), got "
                f"{self.constant_vz!r}"
            )
