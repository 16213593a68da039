"""Escape shaping: when standing still is not safe, the reference becomes the nearest safe one.

A mover on course for the robot (a walker coming head on faster than the robot can back away)
hits a robot that stands still. The C3BF QP answers it myopically: it keeps each constraint's
rate, so it backs away only as fast as the rows demand, and it turns the whole body's front
point out of the cone; turning while backing away swings the retreat to the side opposite the
turn, against the side-step the QP adds at the same time. Measured on random biped seed 8 (a
walker starting 1.08 m ahead at 0.2 m/s, twice the biped's reverse speed): the base's sideways
progress cancelled for 5 s and the walker touched a foot.

This stage, in front of the QP (after the cone steering), looks ahead instead:

* **Trigger:** the robot's cover, standing still, meets a moving vertical obstacle (speed
  above ``MOVER_SPEED``) within ``horizon``, and the reference's own straight path (at the
  present heading) does not stay clear over ``horizon`` either.
* **Escape:** among base_link velocities ``(vx, vy)`` within the robot's limits (forward
  ``max_speed``, back ``max_reverse_speed``, sideways ``max_lateral``), at the present
  heading, the one whose straight path keeps the cover clear of every vertical obstacle over
  ``horizon`` and is nearest the reference; if none is clear, among those that move no cover
  point towards a mover (the barrier would refuse that), the one whose first contact comes
  latest, and among equals (a cover already touching a mover's circle: every velocity slower
  than the mover meets it at once) the one whose closest approach over ``horizon`` keeps the
  most clearance: out of the mover's path, not along it.
* The safety cycle makes it the reference with yaw rate 0, tracked at full acceleration, and
  lets the QP's yaw rate only decay while it escapes (``safety_cycle``): the retreat and the
  side-step add up instead of cancelling.

The QP still filters the shaped reference: no barrier constraint is weakened, and the planner
stays obstacle-agnostic. Velocity obstacles with a time horizon (``velocity_obstacles``, the
cone steering's test), for the whole cover at a fixed heading.

Geometry: odom, m, m/s; the cover is the body's x-y circles (``c3bf.body``) at their offsets
in base_link; obstacle ``j`` a circle of radius ``r_j`` (its size plus the safety margin)
moving at ``w_j``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.safety.velocity_obstacles import closest_clearances, first_contact_times

__all__ = ["MOVER_SPEED", "Escape", "EscapeShaping", "footprint_circles"]

MOVER_SPEED = 0.05
"""Obstacle speed [m/s] from which an obstacle counts as a mover: a static obstacle's tracked
velocity stays below it (at most 0.03 m/s with the oracle's noise, README), so a robot
stopped next to a pillar is not pushed around by its velocity noise."""
DIRECTIONS = 72
"""Candidate directions of travel (every 5 deg) in base_link."""
FRACTIONS = (0.25, 0.5, 0.75, 1.0)
"""Candidate speeds, as fractions of the largest speed in each direction."""


def footprint_circles(body) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001
    """A ``c3bf.body.RobotBody``'s x-y circles: offsets ``(c, 2)`` [m] in base_link, radii."""
    offsets, radii, planes = body.arrays
    vertical = planes == 0
    return offsets[vertical, :2], radii[vertical]


@dataclass(frozen=True)
class Escape:
    """A shaped reference: base_link velocity [m/s], and the first contact it leaves [s]."""

    vx: float
    vy: float
    contact_time: float  # inf: clear over the horizon


class EscapeShaping:
    """Shapes the reference of a robot a mover would hit (see the module docstring)."""

    def __init__(self, horizon: float, cover_offsets, cover_radii) -> None:
        """Configure the stage.

        ``horizon`` [s] (0: off); the cover's x-y circles: offsets ``(c, 2)`` [m] in base_link
        and radii ``(c,)`` [m].
        """
        self.horizon = float(horizon)
        self._offsets = np.asarray(cover_offsets, dtype=float).reshape(-1, 2)
        self._radii = np.asarray(cover_radii, dtype=float).reshape(-1)
        theta = np.arange(DIRECTIONS) * (math.tau / DIRECTIONS)
        self._dirs = np.stack([np.cos(theta), np.sin(theta)], -1)

    @classmethod
    def for_body(cls, body, horizon: float) -> EscapeShaping | None:  # noqa: ANN001
        """The stage over a ``c3bf.body.RobotBody``'s x-y circles.

        None without a body (the point model) or with ``horizon`` 0.
        """
        if body is None or horizon <= 0.0:
            return None
        return cls(horizon, *footprint_circles(body))

    def shape(self, pos, yaw: float, ref, centers, velocities, radii,
              limits) -> Escape | None:
        """The escape velocity, or None (reference kept).

        None when standing still is safe, or when the reference's own path stays clear.

        ``pos`` (x, y) and ``yaw`` of the base in odom; ``ref`` the reference (vx, vy) in
        base_link; ``centers`` ``(n, 2)``, ``velocities`` ``(n, 2)``, ``radii`` ``(n,)`` of the
        vertical obstacles; ``limits`` (forward, reverse, lateral) speeds [m/s].
        """
        w = np.asarray(velocities, dtype=float).reshape(-1, 2)
        movers = np.hypot(w[:, 0], w[:, 1]) > MOVER_SPEED
        if self.horizon <= 0.0 or not movers.any() or len(self._radii) == 0:
            return None
        c, s = math.cos(yaw), math.sin(yaw)
        rot = np.array([[c, -s], [s, c]])
        rel = (np.asarray(centers, dtype=float).reshape(-1, 2)[None]
               - (np.asarray(pos, dtype=float)[:2] + self._offsets @ rot.T)[:, None])  # (c,n,2)
        pair_w = np.broadcast_to(w[None], rel.shape).reshape(-1, 2)
        pair_r = (np.asarray(radii, dtype=float)[None] + self._radii[:, None]).reshape(-1)
        p = rel.reshape(-1, 2)
        forward, reverse, lateral = limits
        wanted = np.array([[0.0, 0.0], [min(max(ref[0], -reverse), forward),
                                        min(max(ref[1], -lateral), lateral)]])
        standing, going = first_contact_times(wanted @ rot.T, p, pair_w, pair_r, self.horizon)
        if math.isinf(standing) or math.isinf(going):
            return None  # standing still is safe, or the reference's own path stays clear
        body = self._candidates(forward, reverse, lateral)
        world = body @ rot.T
        times = first_contact_times(world, p, pair_w, pair_r, self.horizon)
        deviation = np.hypot(body[:, 0] - ref[0], body[:, 1] - ref[1])
        clear = np.isinf(times)
        if clear.any():
            j = int(np.argmin(np.where(clear, deviation, np.inf)))
            return Escape(float(body[j, 0]), float(body[j, 1]), math.inf)
        # None clear: the latest first contact among the velocities that move no cover point
        # towards a mover (the barrier would refuse those); among equals (all at 0 when the
        # cover already touches a mover's circle) the most clearance at the closest approach,
        # then the nearer the reference. The zero velocity always qualifies.
        towards = np.einsum("kd,cnd->kcn", world, rel[:, movers]) > 1e-9
        keep = np.nonzero(~towards.any(axis=(1, 2)))[0]
        closest = closest_clearances(world[keep], p, pair_w, pair_r, self.horizon)
        j = int(keep[np.lexsort((deviation[keep], -closest, -times[keep]))[0]])
        return Escape(float(body[j, 0]), float(body[j, 1]), float(times[j]))

    def _candidates(self, forward: float, reverse: float, lateral: float) -> np.ndarray:
        """``(k, 2)`` base_link velocities: 0, and each direction to the limits' box, scaled."""
        d = self._dirs
        ax, ay = np.abs(d[:, 0]), np.abs(d[:, 1])
        sx = np.where(d[:, 0] > 0, forward, reverse) / np.where(ax > 1e-9, ax, 1.0)
        sx = np.where(ax > 1e-9, sx, np.inf)
        sy = np.where(ay > 1e-9, lateral / np.where(ay > 1e-9, ay, 1.0), np.inf)
        edge = d * np.minimum(sx, sy)[:, None]  # on the box's boundary
        return np.concatenate([np.zeros((1, 2))] + [edge * f for f in FRACTIONS])
