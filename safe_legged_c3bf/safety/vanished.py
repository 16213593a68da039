"""Obstacles that vanish near the robot: remember what was seen, brake for what disappears.

An obstacle the filter was avoiding can disappear from /obstacles for reasons that say
nothing about the world: a detector drop-out, occlusion, a poisoned frame, a tracker that lost
the track. If it vanishes while the robot could not stop before reaching where it was, the
robot brakes to a stop rather than drive on into what may still be there.

:class:`VanishWatch` remembers each identified obstacle's inflated circle (as the C3BF filter
saw it, predicted at its last sighting, and its velocity) for ``memory`` s. An obstacle that
is gone from the current list is a *vanished* one; if its circle, moved on at its last
velocity, comes closer to the robot's body point than the stopping distance plus a margin,
:meth:`VanishWatch.check` names it. Anonymous obstacles (empty id) cannot be followed from
one list to the next and are not watched. Units: m, s, m/s; frame odom (x-y for vertical
obstacles, x-z for horizontal ones).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.c3bf import Obstacles, Plane


@dataclass(frozen=True)
class Sighting:
    """The last sighting of one obstacle: time (s), circle centre, velocity, radius, plane."""

    t: float
    center: tuple[float, float]
    velocity: tuple[float, float]
    radius: float
    plane: int


@dataclass(frozen=True)
class Vanished:
    """A vanished obstacle inside the stopping distance."""

    obstacle_id: str
    clearance: float  # m, from the body point to its (moved-on) inflated circle
    stopping_distance: float  # m


class VanishWatch:
    """Remembers the obstacles seen in the last ``memory`` s (see the module docstring)."""

    def __init__(self) -> None:
        self._seen: dict[str, Sighting] = {}

    def clear(self) -> None:
        """Forget every sighting."""
        self._seen.clear()

    def observe(self, t: float, ids: Iterable[str], circles: Obstacles) -> None:
        """Record the circles the filter used at ``t`` (``ids`` in ``circles`` order)."""
        center = np.asarray(circles.center, dtype=float)[:, :2].tolist()  # floats at once
        velocity = np.asarray(circles.velocity, dtype=float)[:, :2].tolist()
        radius = np.asarray(circles.radius, dtype=float).tolist()
        plane = np.asarray(circles.plane).tolist()
        for k, obstacle_id in enumerate(ids):
            if obstacle_id:
                self._seen[obstacle_id] = Sighting(
                    t, tuple(center[k]), tuple(velocity[k]), radius[k], plane[k],
                )

    def check(
        self,
        t: float,
        present: Iterable[str],
        body_xy: tuple[float, float],
        body_xz: tuple[float, float],
        stopping_distance: float,
        margin: float,
        memory: float,
    ) -> Vanished | None:
        """The nearest obstacle gone from ``present`` within the stopping distance, if any.

        Sightings older than ``memory`` s and vanished obstacles outside the stopping
        distance are forgotten; the one returned is forgotten too (it is acted on once).
        """
        present = set(present)
        worst: Vanished | None = None
        for obstacle_id, seen in list(self._seen.items()):
            if obstacle_id in present:
                continue
            del self._seen[obstacle_id]
            age = t - seen.t
            if age > memory:
                continue
            body = body_xy if seen.plane == int(Plane.VERTICAL) else body_xz
            age = max(age, 0.0)
            dx = body[0] - (seen.center[0] + seen.velocity[0] * age)
            dy = body[1] - (seen.center[1] + seen.velocity[1] * age)
            clearance = math.hypot(dx, dy) - seen.radius
            if clearance < stopping_distance + margin and (
                worst is None or clearance < worst.clearance
            ):
                worst = Vanished(obstacle_id, clearance, stopping_distance)
        return worst
