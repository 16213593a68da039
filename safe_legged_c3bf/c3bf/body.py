"""Robot shape models: the body points and radii a whole-body C3BF keeps out of obstacles.

A :class:`RobotBody` is a small set of :class:`BodyPoint` s, each a circle of radius
``radius`` [m] about a point at ``offset = (l_x, l_y, l_z)`` [m] in the robot's base frame
(``base_link``, REP-103: x forward, y left, z up; the frame ``/odom`` reports). Points with
``plane = VERTICAL`` are circles in x-y whose union covers the robot's footprint (trunk and leg
workspace); points with ``plane = HORIZONTAL`` are circles in x-z whose union covers the
robot's side silhouette, from the trunk's top edge (head included) down to the ground at the
highest body height the gait controller holds. A bar (a HORIZONTAL obstacle) is kept from the
x-z circles, a pillar or a person (VERTICAL) from the x-y ones.

The union covers the body at every body height the controller holds: the x-z points move with
the base height (a crouch lowers them all), and the leg band reaches the ground from the
highest holdable height, so a crouched robot's cover extends below the floor (harmless; no
obstacle lies under the ground).

Inflation, one place: the constraint radius of (point ``k``, obstacle ``i``) is
``obstacle size_i + radius_k + margin`` (``SafetyFilter`` adds its own ``margin`` for
sampling; the safety filter node adds its ``safety_margin`` to the obstacle sizes). Nothing
else is inflated.

The top row of x-z circles (the A1's trunk, the biped's torso and head) has as many circles
as keep its bulge above the top edge within ``TOP_EXCESS`` (2 mm): that edge decides which
bars the robot can duck under (``safety.bar_walls``).

The two robots' covers are derived from their descriptions at the controllers' nominal
postures (collision shapes, PyBullet AABBs in base_link, ``test/test_c3bf_body.py`` checks
that every link's box lies inside the cover) plus the swing reach of the feet:

* A1 (Unitree, ``pybullet_data/a1/a1.urdf``, standing at 0.30-0.32 m): trunk and hips x in
  [-0.232, 0.232], z in [-0.058, +0.058]; rear knees to x = -0.34; toes at x = +-0.183,
  y = +-0.132 nominal (radius 0.02), reaching x +-0.28, y +-0.15 (toe centre) in the trot
  (Raibert footholds); so the footprint is x in [-0.34, 0.30], y in [-0.17, 0.17] and the
  silhouette x in [-0.34, 0.30], z from the ground to base + 0.058.
* Biped (``description/biped.urdf``, base at 0.81-0.825 m): torso x in [-0.081, 0.081],
  y +-0.141, z in [-0.191, +0.231]; thighs and shins forward to x = 0.152; feet x in
  [-0.09, 0.13], y in +-[0.03, 0.15]; steps up to 0.1 m forward or back: footprint x in
  [-0.19, 0.25], y in [-0.15, 0.15]; silhouette z from the ground to base + 0.231 (head).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .domain import checked, checked_scalar
from .errors import InvalidInputError
from .geometry import Plane

__all__ = ["BODIES", "TOP_EXCESS", "BodyPoint", "RobotBody", "cells_for_excess", "cover_box",
           "robot_body"]


@dataclass(frozen=True)
class BodyPoint:
    """One circle of a robot's cover.

    Attributes:
        offset: ``(l_x, l_y, l_z)`` [m] in base_link.
        radius: Circle radius [m] (> 0).
        plane: :class:`~.geometry.Plane` of the obstacles this circle is kept out of.
        name: What part of the body it covers (for messages and plots).

    """

    offset: tuple[float, float, float]
    radius: float
    plane: Plane
    name: str = ""

    def __post_init__(self) -> None:
        """Validate (finite offsets within the library's domain, radius > 0)."""
        off = checked("offset", self.offset)
        if off.shape != (3,):
            raise InvalidInputError(f"offset must have 3 entries, got shape {off.shape}")
        object.__setattr__(self, "offset", tuple(float(v) for v in off))
        r = checked_scalar("radius", self.radius, 0.0, low_open=True)
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "plane", Plane(self.plane))


def cover_box(
    x: tuple[float, float], z: tuple[float, float], n: int, plane: Plane, name: str,
    rows: int = 1, y: float = 0.0,
) -> tuple[BodyPoint, ...]:
    """``n`` by ``rows`` equal circles whose union covers the box ``x`` by ``z`` [m].

    The box is cut into ``n`` cells along x and ``rows`` along z; each circle is its cell's
    circumscribed circle (radius ``sqrt((dx / 2)^2 + (dz / 2)^2)``). ``z`` is the second
    in-plane coordinate: the base-frame y for ``VERTICAL`` points, z for ``HORIZONTAL`` ones
    (then ``y`` is the points' lateral offset).
    """
    (x0, x1), (z0, z1) = x, z
    if not (x1 > x0 and z1 > z0 and n >= 1 and rows >= 1):
        raise InvalidInputError(
            f"cover_box: need x0 < x1, z0 < z1, n >= 1, rows >= 1, got {x}, {z}, {n}, {rows}"
        )
    half_dx, half_dz = 0.5 * (x1 - x0) / n, 0.5 * (z1 - z0) / rows
    radius = math.hypot(half_dx, half_dz)
    points = []
    for j in range(rows):
        zc = z0 + (2 * j + 1) * half_dz
        for i in range(n):
            xc = x0 + (2 * i + 1) * half_dx
            offset = (xc, zc, 0.0) if plane is Plane.VERTICAL else (xc, y, zc)
            label = f"{name} {j * n + i + 1}/{n * rows}"
            points.append(BodyPoint(offset, radius, plane, label))
    return tuple(points)


@dataclass(frozen=True)
class RobotBody:
    """A robot's cover: its body points (see the module docstring).

    Attributes:
        name: Robot name.
        points: The circles, x-y ones and x-z ones.
        half_width: Half the body width [m] (y), for the lateral extent of bars.

    """

    name: str
    points: tuple[BodyPoint, ...]
    half_width: float

    def __post_init__(self) -> None:
        """Validate: at least one point, half width > 0."""
        if not self.points:
            raise InvalidInputError("a RobotBody needs at least one point")
        checked_scalar("half_width", self.half_width, 0.0, low_open=True)

    @cached_property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(offsets (k, 3), radii (k,), planes (k,))`` as read-only arrays."""
        off = np.array([p.offset for p in self.points], dtype=float)
        rad = np.array([p.radius for p in self.points], dtype=float)
        pl = np.array([int(p.plane) for p in self.points], dtype=np.intp)
        for a in (off, rad, pl):
            a.setflags(write=False)
        return off, rad, pl

    def points_in(self, plane: Plane) -> tuple[BodyPoint, ...]:
        """The points kept out of obstacles in ``plane``."""
        return tuple(p for p in self.points if p.plane is plane)


TOP_EXCESS = 0.002
"""How far [m] the x-z circles of the body's top row may bulge above its top edge: a bar
the trunk or head passes with the filter's margins must not be refused for the cover's
bulge (six circles over the A1's trunk bulged 2.1 cm: bars 2 cm above the rule were held)."""


def cells_for_excess(length: float, height: float, excess: float = TOP_EXCESS) -> int:
    """Fewest cells along ``length`` [m] whose circles bulge at most ``excess`` [m].

    The box is ``height`` [m] high, one row: circle radius ``hypot(length / 2n, height / 2)``.
    """
    half_z = 0.5 * height
    half_x = math.sqrt((half_z + excess) ** 2 - half_z**2)
    return max(1, math.ceil(length / (2.0 * half_x)))


def _top_row(x: tuple[float, float], z: tuple[float, float], name: str) -> tuple[BodyPoint, ...]:
    """The x-z top row over the box ``x`` by ``z`` [m], bulging at most ``TOP_EXCESS``."""
    n = cells_for_excess(x[1] - x[0], z[1] - z[0])
    return cover_box(x, z, n, Plane.HORIZONTAL, name)


def _a1() -> RobotBody:
    footprint = cover_box((-0.34, 0.30), (-0.17, 0.17), 3, Plane.VERTICAL, "footprint")
    top = _top_row((-0.34, 0.30), (-0.058, 0.058), "trunk")
    legs = cover_box((-0.34, 0.30), (-0.34, -0.058), 3, Plane.HORIZONTAL, "legs", rows=2)
    return RobotBody("a1", footprint + top + legs, half_width=0.17)


def _biped() -> RobotBody:
    footprint = cover_box((-0.19, 0.25), (-0.15, 0.15), 2, Plane.VERTICAL, "footprint")
    head = _top_row((-0.19, 0.25), (0.111, 0.231), "torso and head")
    legs = cover_box((-0.19, 0.25), (-0.845, 0.111), 2, Plane.HORIZONTAL, "torso and legs",
                     rows=4)
    return RobotBody("biped", footprint + head + legs, half_width=0.15)


BODIES = {"a1": _a1, "quadruped": _a1, "biped": _biped}


def robot_body(name: str) -> RobotBody:
    """The cover of a known robot: 'a1' (or 'quadruped') or 'biped'."""
    try:
        return BODIES[name]()
    except KeyError:
        raise InvalidInputError(f"unknown robot body '{name}', expected one of "
                                f"{sorted(BODIES)}") from None
