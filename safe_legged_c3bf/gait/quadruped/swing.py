"""Swing-foot planning: where a foot lands (Raibert heuristic) and how it gets there.

Foothold (odom frame, horizontal)::

    p_f = p_hip(t_td) + v_hip_des * T_stance / 2 + k_v (v - v_des) + (h / 2g) (v x w_des)

where ``p_hip(t_td)`` is the hip's position projected to the touch-down time along the
commanded motion, ``v_hip_des`` the hip's commanded velocity (body velocity plus the yaw
rate's contribution), ``k_v`` the velocity-feedback gain (about sqrt(h/g)) and the last term
the centripetal correction. The horizontal offset from the projected hip is bounded.

Trajectory: horizontal minimum-jerk interpolation from the lift-off point to the foothold;
vertical minimum-jerk rise to an apex ``apex_height`` above the higher of the two end points
during the first half of the swing, and minimum-jerk descent to the foothold in the second.

The functions work on one leg with plain floats: with two or four legs, numpy's per-call
overhead would dominate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

GRAVITY = 9.81

Vec3 = tuple[float, float, float]


def min_jerk(s: float) -> tuple[float, float]:
    """Minimum-jerk profile ``10 s^3 - 15 s^4 + 6 s^5`` and its derivative, s clipped to [0, 1]."""
    s = min(1.0, max(0.0, s))
    s2 = s * s
    return s2 * s * (10.0 - 15.0 * s + 6.0 * s2), 30.0 * s2 * (1.0 - s) ** 2


def raibert_foothold(
    hip_td: Sequence[float],
    hip_velocity_des: Sequence[float],
    velocity: Sequence[float],
    velocity_des: Sequence[float],
    yaw_rate_des: float,
    stance_duration: float,
    height: float,
    gain: float,
    max_offset: float,
) -> tuple[float, float]:
    """Horizontal foothold (x, y) in odom of one foot.

    Args:
        hip_td: (x, y) hip position projected to touch-down (m).
        hip_velocity_des: (x, y) commanded hip velocity (m/s).
        velocity: measured body velocity, odom axes; x and y are used (m/s).
        velocity_des: commanded body velocity, odom axes; x and y are used (m/s).
        yaw_rate_des: commanded yaw rate (rad/s).
        stance_duration: duration of a stance (s).
        height: body height above the ground (m).
        gain: velocity-feedback gain (s).
        max_offset: bound of the offset from ``hip_td`` (m).

    """
    vx, vy = float(velocity[0]), float(velocity[1])
    k_c = 0.5 * height / GRAVITY * yaw_rate_des
    half = 0.5 * stance_duration
    ox = hip_velocity_des[0] * half + gain * (vx - velocity_des[0]) + k_c * vy
    oy = hip_velocity_des[1] * half + gain * (vy - velocity_des[1]) - k_c * vx
    norm = math.hypot(ox, oy)
    if norm > max_offset:
        scale = max_offset / norm
        ox, oy = ox * scale, oy * scale
    return hip_td[0] + ox, hip_td[1] + oy


def swing_point(
    start: Sequence[float],
    end: Sequence[float],
    progress: float,
    duration: float,
    apex_height: float,
) -> tuple[Vec3, Vec3]:
    """Position and velocity of a swing foot (odom) at ``progress`` in [0, 1] of its swing.

    Args:
        start: (x, y, z) lift-off position (m).
        end: (x, y, z) foothold (m).
        progress: fraction of the swing done.
        duration: swing duration (s).
        apex_height: apex height above the higher end point (m).

    """
    s = min(1.0, max(0.0, progress))
    m, dm = min_jerk(s)
    rate = dm / duration
    x0, y0, z0 = float(start[0]), float(start[1]), float(start[2])
    x1, y1, z1 = float(end[0]), float(end[1]), float(end[2])
    apex = max(z0, z1) + apex_height
    if s < 0.5:
        mz, dmz = min_jerk(2.0 * s)
        z_from, rise = z0, apex - z0
    else:
        mz, dmz = min_jerk(2.0 * s - 1.0)
        z_from, rise = apex, z1 - apex
    pos = (x0 + (x1 - x0) * m, y0 + (y1 - y0) * m, z_from + rise * mz)
    vel = ((x1 - x0) * rate, (y1 - y0) * rate, rise * dmz * 2.0 / duration)
    return pos, vel
