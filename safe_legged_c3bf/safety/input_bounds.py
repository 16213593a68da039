"""Per-cycle input bounds of the safety filter's QP: limits, speeds, height and anti-windup.

Units: m/s^2, rad/s^2 (the inputs' rates), m/s and rad/s (speeds), m (height); base_link
planar velocities, odom vertical (as ``safety_cycle``).
"""

from __future__ import annotations

import math

import numpy as np

from safe_legged_c3bf.safety.params import LATERAL_MODELS, FilterParams

__all__ = ["input_bounds", "yaw_rate_only_decays"]


def input_bounds(
    p: FilterParams, limits: np.ndarray, whole_body: bool, v: np.ndarray, measured: np.ndarray,
    z: float, dt: float, idx: tuple[int, ...], ref_vx: float = math.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-cycle input bounds: limits, velocity limits, height range and anti-windup.

    ``limits``: the inputs' acceleration limits, ``v`` the commanded and ``measured`` the
    measured (vx, vy, vz, yaw rate), ``idx`` the velocity each input integrates into, ``dt``
    the cycle's step [s]. Whole body (``whole_body``): the forward speed stays within
    ``max_speedup`` of the reference's (``ref_vx`` [m/s]); the collision cone is left by
    turning, side-stepping or braking, not by running.
    """
    hi = limits.tolist()
    lo = [-x for x in hi]
    vy_max = p.max_lateral_speed if p.model in LATERAL_MODELS else 0.0
    vx_max = p.max_speed
    if whole_body:
        vx_max = min(vx_max, max(ref_vx, 0.0) + p.max_speedup)
    v_lo = (-p.max_reverse_speed, -vy_max, -p.max_vertical_speed, -p.max_yaw_rate)
    v_hi = (vx_max, vy_max, p.max_vertical_speed, p.max_yaw_rate)
    vl, ml = v.tolist(), measured.tolist()
    for k, j in enumerate(idx):
        lo[k] = max(lo[k], (v_lo[j] - vl[j]) / dt)
        hi[k] = min(hi[k], (v_hi[j] - vl[j]) / dt)
        lead = vl[j] - ml[j]
        if lead > p.windup_band:
            hi[k] = min(hi[k], 0.0)
        elif lead < -p.windup_band:
            lo[k] = max(lo[k], 0.0)
    # Height-range barrier (second order, exponential): min_height <= z <= max_height.
    k_h, vz = p.height_gain, vl[2]
    kz = idx.index(2)
    lo[kz] = max(lo[kz], -2.0 * k_h * vz - k_h * k_h * (z - p.min_height))
    hi[kz] = min(hi[kz], -2.0 * k_h * vz + k_h * k_h * (p.max_height - z))
    for k in range(len(lo)):
        if lo[k] > hi[k]:  # conflicting limits: take the middle (limits are soft here)
            lo[k] = hi[k] = 0.5 * (lo[k] + hi[k])
    return np.array(lo), np.array(hi)


def yaw_rate_only_decays(u_min: np.ndarray, u_max: np.ndarray, wz: float, dt: float,
                         idx: tuple[int, ...]) -> None:
    """Narrow the yaw input's bounds (in place): the yaw rate ``wz`` [rad/s] only decays to 0.

    ``dt`` is the cycle [s], ``idx`` as in :func:`input_bounds`.

    While the robot escapes a mover (``escape``) a turn would swing its retreat to the side
    opposite the turn; the barrier rows, which see only their rates, would otherwise buy a
    moment's clearance of the front point with a turn that undoes the escape's side-step.
    """
    if 3 not in idx:
        return
    k = idx.index(3)
    stop = -wz / dt  # the yaw acceleration that brings wz to 0 in this cycle
    lo, hi = max(u_min[k], min(stop, 0.0)), min(u_max[k], max(stop, 0.0))
    u_min[k], u_max[k] = min(lo, hi), max(lo, hi)
