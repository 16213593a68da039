"""From the velocity command to the reference the quadruped controller's MPC tracks.

* :class:`CommandFilter` clips (vx, vy, yaw_rate) to the limits and rate-limits it (smooth
  start and stop), and tells whether motion is requested and whether the command has settled;
* :class:`IntegralAction` integrates tracking errors into slow corrections of the reference:
  the body height (the MPC's lumped model ignores the legs' own weight) always, the velocity
  and the yaw rate while trotting with a settled command.

Both work on plain floats, one axis at a time: on three numbers numpy's per-call overhead
would dominate (they run at every control tick).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams
from safe_legged_c3bf.gait.quadruped.state_estimate import BodyEstimate
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand

#: speed (m/s, rad/s) above which a command or the filtered command counts as motion
MOTION_EPS = 1e-3


class CommandFilter:
    """Clip and rate-limit the planar command (vx, vy, yaw_rate)."""

    def __init__(self, limits: Sequence[float], accelerations: Sequence[float]) -> None:
        """Create the filter (at rest).

        Args:
            limits: bounds of |vx|, |vy| (m/s) and |yaw_rate| (rad/s).
            accelerations: bounds of their rates of change (m/s^2, rad/s^2).

        """
        self._limits = np.array(limits)
        self._accel = np.array(accelerations)
        self.reset()

    def reset(self) -> None:
        """Come to rest: filtered command zero, no motion requested, settled."""
        #: the rate-limited (vx, vy, yaw_rate)
        self.value = np.zeros(3)
        #: True when the command or the filtered command is not (near) zero
        self.motion_requested = False
        #: True when the filtered command has reached the clipped command
        self.settled = True

    def update(self, command: VelocityCommand, dt: float) -> tuple[float, float, float]:
        """Step the filter by ``dt`` (s) towards ``command``; return the filtered command.

        Non-finite components count as zero.
        """
        out = []
        moving = False
        settled = True
        for i, value in enumerate((command.vx, command.vy, command.yaw_rate)):
            value = float(value) if math.isfinite(value) else 0.0
            limit = float(self._limits[i])
            target = min(limit, max(-limit, value))
            step = float(self._accel[i]) * dt
            current = float(self.value[i])
            current += min(step, max(-step, target - current))
            settled = settled and abs(target - current) < 1e-9
            self.value[i] = current
            moving = moving or abs(target) > MOTION_EPS or abs(current) > MOTION_EPS
            out.append(current)
        self.motion_requested = moving
        self.settled = settled
        return out[0], out[1], out[2]


class IntegralAction:
    """Slow integral corrections of the body height and of the velocity and yaw-rate reference.

    Gains and bounds are ``params``' ``height_integral_gain``, ``max_height_correction``,
    ``velocity_integral_gain``, ``yaw_rate_integral_gain``, ``max_velocity_correction`` and
    ``max_yaw_rate_correction``.
    """

    def __init__(self, params: QuadrupedParams) -> None:
        """Create the integrators (at zero)."""
        self.params = params
        self.reset()

    def reset(self) -> None:
        """Clear the corrections."""
        #: correction (m) added to the body-height reference
        self.height_correction = 0.0
        #: corrections added to (vx, vy, yaw_rate)
        self.velocity_correction = np.zeros(3)

    def update(
        self,
        height_error: float,
        body: BodyEstimate,
        dt: float,
        trotting: bool,
        settled: bool,
        cy: float,
        sy: float,
        vx: float,
        vy: float,
        wz: float,
    ) -> tuple[float, float, float]:
        """Integrate the errors over ``dt``; return the corrected (vx, vy, wz).

        Args:
            height_error: body-height target minus measured height (m).
            body: body estimate (velocity and angular velocity in odom axes).
            dt: time step (s).
            trotting: False clears the velocity corrections (standing).
            settled: the velocity corrections integrate only when the command has settled.
            cy: cosine of the heading (the velocity errors are taken in the heading frame).
            sy: sine of the heading.
            vx: filtered forward speed (m/s).
            vy: filtered lateral speed (m/s).
            wz: filtered yaw rate (rad/s).

        """
        p = self.params
        lim = p.max_height_correction
        self.height_correction = min(
            lim, max(-lim, self.height_correction + p.height_integral_gain * height_error * dt)
        )
        corr = self.velocity_correction
        if not trotting:
            corr[:] = 0.0
            return vx, vy, wz
        if settled:
            v0, v1 = float(body.velocity[0]), float(body.velocity[1])
            errors = (
                vx - (cy * v0 + sy * v1),
                vy - (-sy * v0 + cy * v1),
                wz - float(body.angular_velocity[2]),
            )
            gains = (p.velocity_integral_gain, p.velocity_integral_gain, p.yaw_rate_integral_gain)
            limits = (
                p.max_velocity_correction,
                p.max_velocity_correction,
                p.max_yaw_rate_correction,
            )
            for i in range(3):
                value = float(corr[i]) + gains[i] * errors[i] * dt
                corr[i] = min(limits[i], max(-limits[i], value))
        return vx + float(corr[0]), vy + float(corr[1]), wz + float(corr[2])
