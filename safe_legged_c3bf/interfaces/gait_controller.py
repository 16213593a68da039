"""The interface every gait controller implements, so one ROS node can host any of them.

A gait controller turns a body-frame velocity command (REP-103 base_link: x forward, y left,
z up) and the measured robot state into a joint-level motor command. It holds no ROS objects.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.joint_command import JointCommand


@dataclass(frozen=True)
class VelocityCommand:
    """Body-frame velocity command, the content of a geometry_msgs/Twist on /cmd_vel_safe.

    Attributes:
        vx: forward speed (m/s).
        vy: leftward speed (m/s).
        vz: vertical speed of the body (m/s): negative ducks, positive rises.
        yaw_rate: rate of turn about z (rad/s).

    """

    vx: float = 0.0
    vy: float = 0.0
    vz: float = 0.0
    yaw_rate: float = 0.0

    def as_array(self) -> np.ndarray:
        """Return (vx, vy, vz, yaw_rate)."""
        return np.array([self.vx, self.vy, self.vz, self.yaw_rate])

    def is_zero(self, tol: float = 1e-6) -> bool:
        """Return True when every component is within ``tol`` of zero."""
        return bool(np.all(np.abs(self.as_array()) <= tol))


class GaitController(Protocol):
    """What the gait controller node needs from a controller."""

    #: actuated joint names, in the order of ``q``/``dq`` passed to :meth:`update`.
    joint_names: list[str]
    #: period (s, sim time) at which :meth:`update` is meant to be called.
    control_period: float

    def update(
        self,
        t: float,
        base: BaseState,
        q: np.ndarray,
        dq: np.ndarray,
        command: VelocityCommand,
    ) -> JointCommand:
        """Return the motor command for time ``t`` (s) given the measured state."""
        ...
