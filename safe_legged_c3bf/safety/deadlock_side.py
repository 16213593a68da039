"""The side of the point model's deadlock turn: away from the obstacles nearest its body point.

Odom frame, m, rad. Used by the safety filter cycle's deadlock turn (the paper's single body
point; the whole-body model steers with ``cone_steering`` instead).
"""

from __future__ import annotations

import math

import numpy as np


def deadlock_side(circles, pos, yaw: float, offset: float) -> int:  # noqa: ANN001
    """Turn side (+1 left, -1 right) for the deadlock turn; 0 without vertical obstacles.

    ``circles``: the filter's :class:`~safe_legged_c3bf.c3bf.Obstacles`; ``pos``: the base
    position; ``offset``: the body point's distance ahead of the base [m]. The side whose
    body-point motion points most away from the obstacles within 1 m of their circles; on a
    tie, the side that passes the nearest one as the tie-break does.
    """
    vertical = np.asarray(circles.plane) == 0
    if not vertical.any():
        return 0
    c, s = math.cos(yaw), math.sin(yaw)
    body = np.array([pos[0] + offset * c, pos[1] + offset * s])
    away = body - circles.center[vertical]  # from each obstacle to the body point
    dist = np.linalg.norm(away, axis=1)
    gap = dist - circles.radius[vertical]
    near = gap < 1.0
    if near.any():
        unit = away[near] / np.maximum(dist[near], 1e-9)[:, None]
        left = np.array([-s, c])  # body-point velocity direction of a left turn
        score_left = float(np.min(unit @ left))
        score_right = float(np.min(unit @ -left))
        if abs(score_left - score_right) > 0.1:
            return 1 if score_left > score_right else -1
    nearest = -away[int(np.argmin(gap))]
    lateral = -s * nearest[0] + c * nearest[1]  # + = obstacle on the left
    return -1 if lateral > 0.0 else 1
