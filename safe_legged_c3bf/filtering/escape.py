"""Emergency escape for the unicycle: the reachable motion that leaves obstacles fastest.

When the body point is already inside an inflated circle the C3BF constraint no longer
describes a safe set, and the core filter's emergency action accelerates the body point
radially away from the obstacle centre. For a unicycle that is a poor escape in two common
cases, both seen on the biped:

* the radial direction lies behind the robot and its reverse limit (0.08 m/s for the biped)
  is slower than an obstacle walking at it: backing off loses ground;
* most of the radial direction is sideways, which the body point only gets by turning in
  place: the body point swings round the axis while the robot's feet stay where they are.

:func:`unicycle_escape` instead rolls the unicycle forward over a short horizon for a few
reachable commands (forward at its limit, standing, reverse at its limit; each with a few
yaw rates), with every obstacle moving at its estimated velocity, and picks the command
whose body point keeps the most clearance over the horizon. Pure numpy, no ROS.

Units and frames: odom frame (REP-103), SI units; ``yaw`` counter-clockwise from odom x.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = ["EscapeChoice", "unicycle_escape"]

_YAW_FRACTIONS = (-1.0, -0.5, 0.0, 0.5, 1.0)  # candidate yaw rates, fractions of the limit


class EscapeChoice(NamedTuple):
    """Chosen escape: target forward speed (m/s) and yaw rate (rad/s), and its score (m s)."""

    speed: float
    yaw_rate: float
    score: float


def unicycle_escape(
    pose: tuple[float, float, float],
    velocity: tuple[float, float],
    centers: np.ndarray,
    velocities: np.ndarray,
    radii: np.ndarray,
    *,
    offset: float,
    max_speed: float,
    max_reverse_speed: float,
    max_yaw_rate: float,
    max_accel: float,
    max_yaw_accel: float,
    horizon: float,
    step: float = 0.1,
) -> EscapeChoice:
    """Pick the speed/yaw-rate target whose roll-out keeps the most clearance.

    Args:
        pose: robot ``(x, y, yaw)`` (m, m, rad), the unicycle axis (not the body point).
        velocity: current commanded ``(v, omega)`` (m/s, rad/s).
        centers: ``(n, 2)`` obstacle circle centres (m); n >= 1.
        velocities: ``(n, 2)`` their velocities (m/s).
        radii: ``(n,)`` their inflated radii about the body point (m).
        offset: body-point offset ahead of the axis (m).
        max_speed: forward speed limit (m/s, >= 0).
        max_reverse_speed: backward speed limit (m/s, >= 0).
        max_yaw_rate: yaw-rate limit (rad/s, >= 0).
        max_accel: rate (m/s^2, > 0) at which the speed moves to its target.
        max_yaw_accel: rate (rad/s^2, > 0) at which the yaw rate moves to its target.
        horizon: roll-out length (s, > 0).
        step: roll-out time step (s).

    Returns:
        The target with the largest score: the body point's clearance to the nearest circle
        (distance to centre minus radius, negative inside), summed over the roll-out's steps
        and multiplied by ``step``. Ties go to the target nearest the current velocity.

    """
    x0, y0, th0 = pose
    v0, w0 = velocity
    speeds = np.array([max_speed, 0.0, -max_reverse_speed])
    rates = max_yaw_rate * np.array(_YAW_FRACTIONS)
    v_t = np.repeat(speeds, len(rates))  # (m,) candidate targets
    w_t = np.tile(rates, len(speeds))
    k = max(1, math.ceil(horizon / step))
    t = step * np.arange(1, k + 1)  # (k,)
    # Velocities ramp from the current ones to the targets at the rate limits.
    v = v0 + np.clip(v_t[:, None] - v0, -max_accel * t, max_accel * t)  # (m, k)
    w = w0 + np.clip(w_t[:, None] - w0, -max_yaw_accel * t, max_yaw_accel * t)
    th = th0 + step * np.cumsum(w, axis=1)
    x = x0 + step * np.cumsum(v * np.cos(th), axis=1)
    y = y0 + step * np.cumsum(v * np.sin(th), axis=1)
    px = x + offset * np.cos(th)  # body point, (m, k)
    py = y + offset * np.sin(th)
    cx = centers[:, 0][:, None] + velocities[:, 0][:, None] * t  # (n, k)
    cy = centers[:, 1][:, None] + velocities[:, 1][:, None] * t
    dist = np.hypot(px[:, None, :] - cx[None], py[:, None, :] - cy[None])  # (m, n, k)
    clearance = (dist - radii[None, :, None]).min(axis=1)  # nearest circle, (m, k)
    score = step * clearance.sum(axis=1)
    # Prefer the change of least effort among (near) ties.
    effort = np.abs(v_t - v0) / max(max_speed, 1e-9) + np.abs(w_t - w0) / max(max_yaw_rate, 1e-9)
    best = int(np.argmax(score - 1e-6 * effort))
    return EscapeChoice(float(v_t[best]), float(w_t[best]), float(score[best]))
