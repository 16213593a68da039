"""Velocity obstacles with a time horizon: when a robot velocity first meets an obstacle.

The test behind the whole-body filter's reference shaping in front of the QP: the cone
steering (``cone_steering``: which headings are blocked) and the escape from movers
(``escape``: which velocities stay clear, and for how long the others do). Circles moving at
constant velocity; odom frame, m, m/s, s.
"""

from __future__ import annotations

import numpy as np

__all__ = ["closest_clearances", "closest_clearances_batched", "contact_times_batched",
           "first_contact_times"]


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
    t = _contact_times(vv, pv, (p * p).sum(-1) - radius**2, horizon)
    return t.min(axis=1) if t.shape[1] else np.full(len(vel), np.inf)


def contact_times_batched(vel, p, w, radius, horizon) -> np.ndarray:
    """:func:`first_contact_times` for ``B`` batches at once: ``(B, k)`` times [s].

    ``vel`` ``(B, k, 2)``, ``p`` ``(B, m, 2)`` (each batch its own cover position), ``w``
    ``(m, 2)``, ``radius`` ``(m,)``; ``horizon`` [s] a scalar or ``(B,)``.
    """
    vx, vy, vv, pv = _relative_batched(vel, p, w)
    gap = (p * p).sum(-1) - radius**2  # (B, m)
    t = _contact_times(vv, pv, gap[:, None], np.reshape(horizon, (-1, 1, 1)))
    return t.min(axis=2) if t.shape[2] else np.full(t.shape[:2], np.inf)


def _contact_times(vv, pv, gap, horizon) -> np.ndarray:
    """Per pair and velocity: the first contact [s] (inf: none within ``horizon``).

    ``vv`` = ``||w - v||^2``, ``pv`` = ``<p, w - v>``, ``gap`` = ``||p||^2 - radius^2``, all
    broadcast together (``horizon`` too).
    """
    disc = pv * pv - vv * gap
    moving = vv > 1e-12
    closing = pv < 0.0
    approaching = closing & (disc >= 0.0) & moving
    root = np.sqrt(np.maximum(disc, 0.0))
    t = np.where(approaching, (-pv - root) / np.where(moving, vv, 1.0), np.inf)
    t = np.where(gap <= 0.0, np.where(closing, 0.0, np.inf), t)
    t[~(t <= horizon)] = np.inf  # (NaN too)
    return t


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
    return _closest(p[:, 0], p[:, 1], vx, vy, vv, pv, radius, horizon).min(axis=1)


def closest_clearances_batched(vel, p, w, radius, horizon) -> np.ndarray:
    """:func:`closest_clearances` for ``B`` batches: ``(B, k)`` clearances [m].

    Arguments as in :func:`contact_times_batched` (a negative horizon counts as 0).
    """
    if not len(radius):
        return np.full(np.shape(vel)[:2], np.inf)
    vx, vy, vv, pv = _relative_batched(vel, p, w)
    end = np.maximum(np.reshape(horizon, (-1, 1, 1)), 0.0)
    return _closest(p[:, None, :, 0], p[:, None, :, 1], vx, vy, vv, pv, radius, end).min(axis=2)


def _closest(px, py, vx, vy, vv, pv, radius, horizon) -> np.ndarray:
    """Per pair and velocity: the clearance [m] at closest approach within ``horizon``."""
    t = np.clip(-pv / np.where(vv > 1e-12, vv, 1.0), 0.0, horizon)  # time of closest approach
    dx = px + vx * t
    dy = py + vy * t
    return np.sqrt(dx * dx + dy * dy) - radius


def _relative(vel, p, w) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(k, m)`` relative velocity components, its squared norm and its product with ``p``."""
    vx = w[:, 0] - vel[:, 0, None]
    vy = w[:, 1] - vel[:, 1, None]
    return vx, vy, vx * vx + vy * vy, p[:, 0] * vx + p[:, 1] * vy


def _relative_batched(vel, p, w) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_relative` with a leading batch axis: ``(B, k, m)`` each.

    Kept apart from it: one function for both (``...`` indexing) cost the unbatched form,
    called several times per filter cycle, 3-5 us more a call (measured on a busy machine).
    """
    vx = w[:, 0] - vel[:, :, 0, None]
    vy = w[:, 1] - vel[:, :, 1, None]
    return vx, vy, vx * vx + vy * vy, p[:, None, :, 0] * vx + p[:, None, :, 1] * vy
