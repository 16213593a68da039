"""Velocity command shaping: clipped to the limits, then acceleration-limited.

Commands are (vx, vy, yaw_rate) in base_link (REP-103: x forward, y left, yaw about z up);
units m/s and rad/s.
"""

from __future__ import annotations

import numpy as np

from safe_legged_c3bf.gait.biped.footstep_planner import clamp
from safe_legged_c3bf.gait.biped.params import CommandLimits
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand

#: a speed (m/s or rad/s) below which the command counts as "stand still"
_MOTION_EPS = 1e-4


class CommandFilter:
    """The command the gait follows, and whether the robot is asked to move.

    Attributes:
        velocity: (3,) rate-limited (vx, vy, yaw_rate) the footsteps are planned from.
        target: (3,) the last command clipped to the limits (not rate-limited).
        moving: True while the target or the rate-limited command is not zero.

    """

    def __init__(self, limits: CommandLimits) -> None:
        """Shape commands within ``limits``."""
        self.limits = limits
        self.reset()

    def reset(self) -> None:
        """Back to a zero command."""
        self.velocity = np.zeros(3)
        self.target = np.zeros(3)
        self.moving = False

    def update(self, command: VelocityCommand, dt: float) -> None:
        """Clip ``command`` and move :attr:`velocity` towards it by at most ``dt`` s of accel."""
        lim = self.limits
        target = lim.clip(command.vx, command.vy, command.yaw_rate)
        rates = (lim.accel_x * dt, lim.accel_y * dt, lim.accel_yaw * dt)
        current = self.velocity.tolist()
        self.velocity = np.array(
            [c + clamp(float(g) - c, -r, r) for c, g, r in zip(current, target, rates, strict=True)]
        )
        self.target = target
        self.moving = max(abs(float(v)) for v in (*target, *self.velocity)) > _MOTION_EPS
