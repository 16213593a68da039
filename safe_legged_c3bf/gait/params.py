"""The gait controller node's parameters (no ROS); ``config/gait_controller.yaml``.

The gait itself is configured by the controller's own file (``controller_config``, default
``config/<robot>_controller.yaml``), not by node parameters. ``robot``, ``controller_config``
and ``diagnostics_period`` are fixed at start-up; the stamp limits can change while it runs.
"""

from __future__ import annotations

from dataclasses import dataclass

from safe_legged_c3bf.interfaces.typed_params import (
    NON_EMPTY,
    NON_NEGATIVE,
    POSITIVE,
    TEXT,
    TypedParams,
    at_least,
    param,
)


@dataclass(frozen=True)
class GaitControllerParams(TypedParams):
    """Gait controller node parameters (floats refuse integers)."""

    int_for_float = False  # the node always typed its doubles strictly

    robot: str = param(
        "quadruped", "-", "robot kind (a name): 'quadruped' (or 'a1': the A1 convex-MPC trot) "
        "or 'biped' (the ZMP walk); safe_legged_c3bf.gait.factory knows them", NON_EMPTY,
        fixed=True,
    )
    command_timeout: float = param(
        0.5, "s", "no /cmd_vel_safe for this long (sim time) -> zero command: the robot stops "
        "and stands; also the oldest accepted stamp of /imu, /joint_states and /odom",
        POSITIVE,
    )
    controller_config: str = param(
        "", "-", "YAML file of the controller's parameters (a path); '' = the package's "
        "config/<robot>_controller.yaml", TEXT, fixed=True,
    )
    diagnostics_period: float = param(
        1.0, "s", "period of /diagnostics (sim time)", POSITIVE, fixed=True
    )
    max_future_stamp: float = param(
        0.1, "s", "how far a stamp of /imu, /joint_states or /odom may be ahead of the node's "
        "clock; later stamps are rejected (a publisher not on sim time)", NON_NEGATIVE,
    )
    start_subscribers: int = param(
        1, "-", "hold the first command until /joint_commands has this many subscribers (the "
        "simulator; 2 with the bringup's --record, so the recording has every command)",
        at_least(1), fixed=True,
    )
    start_wait: float = param(
        10.0, "s", "longest wall-clock hold for start_subscribers; then start anyway, warned",
        POSITIVE, fixed=True,
    )
