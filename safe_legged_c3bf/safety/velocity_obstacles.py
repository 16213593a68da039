"""Velocity obstacles with a time horizon: when a robot velocity first meets an obstacle.

The test behind the whole-body filter's reference shaping in front of the QP: the cone
steering (``cone_steering``: which headings are blocked) and the escape from movers
(``escape``: which velocities stay clear, and for how long the others do). Circles moving at
constant velocity; odom frame, m, m/s, s.
"""

from __future__ import annotations

import numpy as np

__all__ = ["closest_clearances", "first_contact_times"]


def first_contact_times(vel, p, w, radius, horizon: float) -> np.ndarray:
    """``(k,)`` time [s] at which robot velocity ``vel[j]`` first brings a pair into contact.

    Args:
        vel: ``(k, 2)`` robot velocities [m/s] (odom).
        p: ``(m, 2)`` obstacle centres minus the cover points' centres [m], one row per
            (cover point, obstacle) pair.
        w: ``(m, 2)`` the pairs' obstacle velocities [m/s].
        radius: ``(m,)`` the pairs' contact distances [m].
        horizon: Look-ahead [s]; no contact within it gives ``inf``.

    A pair already in contact counts as a contact at 0 while it closes in, and none while it
    separates (the QP's inside handling answers it).

    """
    # Components apart: no (k, m, 2) temporaries (the cone steering and the escape call this
    # several times per filter cycle). Same arithmetic, in the same order, as the vector form.
    vx, vy, vv, pv = _relative(vel, p, w)
    gap = (p * p).sum(-1) - radius**2  # (m,)
    disc = pv * pv - vv * gap
    moving = vv > 1e-12
    closing = pv < 0.0
    approaching = closing & (disc >= 0.0) & moving
    root = np.sqrt(np.maximum(disc, 0.0))
    t = np.where(approaching, (-pv - root) / np.where(moving, vv, 1.0), np.inf)
    t = np.where(gap <= 0.0, np.where(closing, 0.0, np.inf), t)
    t[~(t <= horizon)] = np.inf  # (NaN too)
    return t.min(axis=1) if t.shape[1] else np.full(len(vel), np.inf)


def closest_clearances(vel, p, w, radius, horizon: float) -> np.ndarray:
    """``(k,)`` least clearance [m] over the pairs and over ``[0, horizon]`` for each velocity.

    For robot velocity ``vel[j]`` and each pair, the distance of closest approach of the
    centres within the horizon, ``min_t ||p + (w - vel[j]) t||``, minus the contact distance;
    the least over the pairs (negative: in contact then; ``inf`` without pairs). Arguments as
    in :func:`first_contact_times`.
    """
    if not len(radius):
        return np.full(len(vel), np.inf)
    vx, vy, vv, pv = _relative(vel, p, w)
    t = np.clip(-pv / np.where(vv > 1e-12, vv, 1.0), 0.0, horizon)  # time of closest approach
    dx = p[:, 0] + vx * t
    dy = p[:, 1] + vy * t
    return (np.sqrt(dx * dx + dy * dy) - radius).min(axis=1)


def _relative(vel, p, w) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(k, m)`` relative velocity components, its squared norm and its product with ``p``."""
    vx = w[:, 0] - vel[:, 0, None]
    vy = w[:, 1] - vel[:, 1, None]
    return vx, vy, vx * vx + vy * vy, p[:, 0] * vx + p[:, 1] * vy
