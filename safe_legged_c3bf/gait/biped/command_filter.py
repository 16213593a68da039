"""Velocity command shaping: clipped to the limits, then acceleration-limited; stop or go.

Commands are (vx, vy, yaw_rate) in base_link (REP-103: x forward, y left, yaw about z up);
units m/s and rad/s.

Whether the robot walks is decided with hysteresis and latched: a standing robot starts when
a commanded component exceeds ``start_threshold``; a walking robot stops when the command
and its rate-limited value fall below ``stop_threshold``, and once it has decided to stop it
finishes the stop (the gait is standing again) before a command can start a new walk. A stop
is never delayed; only a restart is. Without the latch, a command flickering around zero (a
safety filter holding the robot, solver noise of 1e-4 m/s, or stop-and-go at 0.05 m/s every
0.6-0.9 s) switched the preview and the capture-point target between "stop after this step"
and "walk on" within a step, and the biped fell sideways.
"""

from __future__ import annotations

import numpy as np

from safe_legged_c3bf.gait.biped.footstep_planner import clamp
from safe_legged_c3bf.gait.biped.params import CommandLimits
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand


class CommandFilter:
    """The command the gait follows, and whether the robot is asked to move.

    Attributes:
        velocity: (3,) rate-limited (vx, vy, yaw_rate) the footsteps are planned from.
        target: (3,) the last command clipped to the limits (not rate-limited).
        moving: True while the robot is to walk (see the module docstring for when it
            starts and stops).

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

    def update(self, command: VelocityCommand, dt: float, standing: bool = True) -> None:
        """Clip ``command`` and move :attr:`velocity` towards it by at most ``dt`` s of accel.

        ``standing`` tells whether the gait stands on both feet (a walk may only start then).
        """
        lim = self.limits
        target = lim.clip(command.vx, command.vy, command.yaw_rate)
        rates = (lim.accel_x * dt, lim.accel_y * dt, lim.accel_yaw * dt)
        current = self.velocity.tolist()
        self.velocity = np.array(
            [c + clamp(float(g) - c, -r, r) for c, g, r in zip(current, target, rates, strict=True)]
        )
        self.target = target
        if self.moving:
            size = max(abs(float(v)) for v in (*target, *self.velocity))
            self.moving = size >= lim.stop_threshold
        elif standing:
            self.moving = max(abs(float(v)) for v in target) > lim.start_threshold
