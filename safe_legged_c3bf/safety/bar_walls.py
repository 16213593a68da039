"""Bars the whole body cannot pass under, turned into walls in x-y for the filter.

A bar (a HORIZONTAL obstacle, an ellipse in x-z extruded along odom y) is kept from the
body's x-z circles: the collision cone lets the robot duck and go on. A bar too low for the
body at its lowest holdable height (``min_height``) cannot be passed at all, yet its cone in
x-z only asks the robot to duck while approaching: with the planner asking for the standing
height and the goal behind the bar, the robot ducks, rises, gains a little each time and
creeps into the bar (issue #16). Such a bar is therefore handed to the filter as what it is
to this robot, a wall: its x-y footprint (the rectangle ``[-x_half, x_half]`` by
``[-extent / 2, extent / 2]`` about its centre, ``x_half`` the x half-extent of its ellipse),
kept from the x-y circles like a wall segment (``elongated``, with circles that stick out up
to ``WALL_BULGE`` towards the robot: few rows for the QP), ends included. The barrier never
lets a body approach a wall head-on, so no ducking buys progress. A way round a bar across
the path is the planner's to find, not the filter's: the cone steering does not detour
around such a wall, and while the reference's straight path (at the present heading) would
bring the cover into the wall, the safety cycle holds the reference's
planar velocity at zero (:meth:`BarWalls.blocks`). Without that hold the QP slides the robot
along the wall with its side-step (the velocity that keeps every row and is nearest a
forward reference), on measured-velocity noise alone, and round the wall's end. So the
robot stops where it is when the bar comes into view and holds that stop whatever the
planner keeps asking; a reference that turns away or asks to back off is followed.

Impassable here means, with the filter's own numbers: at base height ``min_height`` some
x-z body point ``k`` (height ``min_height + l_z,k``, radius ``r_k``) lies within the bar's
constraint circle in height, ``|z_j - (min_height + l_z,k)| < R_j + r_k`` for one of the
bar's covering circles ``j`` (centre height ``z_j``, radius ``R_j`` grown by the safety
margins): passing under it would put that point inside the circle. The shortfall is the
bar's deficit (:meth:`BarWalls.deficit`); a tracked bar is walled on its deficit averaged
over a second, after a second of settling, with a 1 cm hysteresis (:meth:`BarWalls.decide`):
a bar whose measured height is noisy near the rule otherwise switched between wall and bar
every message and the robot wandered (random A1 seed 46, a bar passable by 2 mm), and one
noisy first sighting walled a passable bar for good (random biped seed 7). Ducking lower is
not allowed, rising only lifts the trunk into a low bar (the leg band reaches the ground), so
``min_height`` is the only height to check.

A bar the robot is already under (an x-y body circle overlaps the footprint, no margins:
a bar lowered onto the robot) stays a bar, so the x-z barrier keeps steering the robot out;
as a wall the robot would be inside it. Units: m; frames: odom, base_link (REP-103/105).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from safe_legged_c3bf.c3bf.body import RobotBody
from safe_legged_c3bf.c3bf.geometry import Plane
from safe_legged_c3bf.safety.velocity_obstacles import first_contact_times

__all__ = [
    "WALL_BAND", "WALL_BULGE", "WALL_FORGET", "WALL_SETTLE", "WALL_SURE", "WALL_TAU", "BarWalls",
    "bar_extents",
]

WALL_TAU = 1.0
"""Averaging time [s] of a tracked bar's deficit (``BarWalls.decide``)."""
WALL_BAND = 0.01
"""Hysteresis [m] around the rule for tracked bars (``BarWalls.decide``)."""
WALL_SETTLE = 1.0
"""A newly seen bar's deficit is averaged (plain mean) this long [s] before the hysteresis
decides (``BarWalls.decide``): a track's first estimates carry the detections' full noise."""
WALL_SURE = 0.03
"""Deficit [m] (mean so far) above which a bar is a wall while it settles."""
WALL_FORGET = 2.0
"""A bar not seen for this long [s] is forgotten (``BarWalls.decide``)."""
WALL_BULGE = 0.2
"""How far [m] the circles covering a walled bar's footprint stick out beyond its half
thickness: a 4 m bar 0.1 m thick is 9 circles, not 27 (3 rows per x-y body point each)."""


def bar_extents(semi_axes: np.ndarray, orientation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half-extents ``(x_half, z_half)`` [m] of rotated ellipses (their bounding boxes).

    ``semi_axes`` ``(n, 2)`` = ``(a, b)``, ``a`` at ``orientation`` [rad] from odom x in x-z.
    """
    a, b = semi_axes[:, 0], semi_axes[:, 1]
    c, s = np.cos(orientation), np.sin(orientation)
    return np.hypot(a * c, b * s), np.hypot(a * s, b * c)


@dataclass
class BarWalls:
    """Which bars a body cannot pass under at ``min_height`` (see the module docstring).

    Attributes:
        min_height: lowest base height the filter lets the robot hold [m].
        xz_height: ``(k,)`` heights ``l_z`` of the x-z body points above the base [m].
        xz_radius: ``(k,)`` their radii [m].
        xy_offset: ``(m, 2)`` x-y body points in base_link [m].
        xy_radius: ``(m,)`` their radii [m].
        margin: the QP's own margin on every constraint radius [m] (``SafetyFilter.margin``).

    """

    min_height: float
    xz_height: np.ndarray
    xz_radius: np.ndarray
    xy_offset: np.ndarray
    xy_radius: np.ndarray
    margin: float = 0.0
    judge_range: float = 0.0
    _memory: dict = field(default_factory=dict, repr=False)  # id -> _BarMemory

    @classmethod
    def for_body(cls, body: RobotBody | None, min_height: float,
                 margin: float = 0.0, judge_range: float = 0.0) -> BarWalls | None:
        """The check for ``body`` (None for the single-point filter: the paper's, unchanged).

        ``judge_range`` [m]: bars are judged only within it (:meth:`out_of_range`; 0: any).
        """
        if body is None:
            return None
        xz = body.points_in(Plane.HORIZONTAL)
        xy = body.points_in(Plane.VERTICAL)
        if not xz or not xy:
            return None
        return cls(
            float(min_height),
            np.array([p.offset[2] for p in xz]), np.array([p.radius for p in xz]),
            np.array([p.offset[:2] for p in xy]), np.array([p.radius for p in xy]),
            float(margin), float(judge_range),
        )

    def out_of_range(self, pos: np.ndarray, centre_xy: np.ndarray, x_half: np.ndarray,
                     y_half: np.ndarray) -> np.ndarray:
        """``(n,)`` mask: the base is farther than ``judge_range`` from the footprints.

        Such bars are not judged yet: a range sensor measures a far bar's height least well
        (the detector's underside errs low by up to one row of its 3-D sensor, a distance
        times the row spacing), and walling a passable bar from afar holds the robot there for
        good. They stay bars, kept from the body's x-z circles. All False when
        ``judge_range`` is 0. Arguments as in :meth:`under` (``pos``: odom, m).
        """
        if self.judge_range <= 0.0:
            return np.zeros(len(x_half), dtype=bool)
        dx = np.maximum(np.abs(pos[0] - centre_xy[:, 0]) - x_half, 0.0)
        dy = np.maximum(np.abs(pos[1] - centre_xy[:, 1]) - y_half, 0.0)
        return np.hypot(dx, dy) > self.judge_range

    def deficit(
        self, bar_z: np.ndarray, bar_radius: np.ndarray, index: np.ndarray, n: int
    ) -> np.ndarray:
        """``(n,)`` by how much [m] each obstacle is too low to duck under (> 0: impassable).

        The largest ``R_j + r_k - |z_j - (min_height + l_z,k)|`` over the obstacle's circles
        ``j`` and the x-z body points ``k``; ``-inf`` for an obstacle without circles here.

        Args:
            bar_z: ``(m,)`` centre heights of the covering circles [m] (predicted, odom).
            bar_radius: ``(m,)`` their radii grown by every margin the filter uses [m].
            index: ``(m,)`` the obstacle of each circle.
            n: number of obstacles.

        """
        points_z = self.min_height + self.xz_height
        gap = np.abs(bar_z[:, None] - points_z[None, :])
        per_circle = (bar_radius[:, None] + self.xz_radius[None, :] - gap).max(axis=1)
        out = np.full(n, -np.inf)
        np.maximum.at(out, index, per_circle)
        return out

    def decide(self, ids: Sequence[str], deficit: np.ndarray, t: float | None) -> np.ndarray:
        """``(n,)`` mask of the obstacles to wall, from their ``deficit`` at time ``t`` [s].

        Tracked bars (a non-empty id) are decided on an averaged deficit. For its first
        ``WALL_SETTLE`` the average is the plain mean of the deficits seen so far, and the bar
        is a wall once that mean exceeds ``WALL_SURE`` (clearly too low); when it has settled,
        a wall if the mean exceeds ``+WALL_BAND``. Then the average follows the deficit over
        ``WALL_TAU`` with a hysteresis of ``WALL_BAND``: a bar becomes a wall when the average
        exceeds ``+WALL_BAND`` and stops being one below ``-WALL_BAND``; within the band it
        stays what it was. So perception noise on its height and size does not switch it back
        and forth every message, and one noisy first sighting of a bar passable by a few mm
        does not make a wall for the rest of the run (random biped seed 7). A bar not walled
        is still kept from the x-z circles. Without an id, or with ``t`` None: the rule at
        this instant.
        """
        out = np.asarray(deficit) > 0.0
        if t is None:
            return out
        memory = self._memory
        for i, (key, d) in enumerate(zip(ids, np.asarray(deficit).tolist(), strict=True)):
            if not key or not math.isfinite(d):
                continue
            seen = memory.get(key)
            if seen is None:
                seen = memory[key] = _BarMemory(d, d > WALL_SURE, t, t)
            else:
                seen.update(d, t)
            out[i] = seen.walled
        for key in [k for k, entry in memory.items() if t - entry.last > WALL_FORGET]:
            del memory[key]
        return out

    def under(self, pos: np.ndarray, yaw: float, centre_xy: np.ndarray, x_half: np.ndarray,
              y_half: np.ndarray) -> np.ndarray:
        """``(n,)`` mask: an x-y body circle overlaps the footprint rectangle (no margins).

        Args:
            pos: base position in odom [m] (x, y used).
            yaw: base yaw [rad].
            centre_xy: ``(n, 2)`` footprint centres [m].
            x_half: ``(n,)`` half-sizes along odom x [m].
            y_half: ``(n,)`` half-sizes along odom y [m].

        """
        c, s = math.cos(yaw), math.sin(yaw)
        px = pos[0] + c * self.xy_offset[:, 0] - s * self.xy_offset[:, 1]
        py = pos[1] + s * self.xy_offset[:, 0] + c * self.xy_offset[:, 1]
        dx = np.maximum(np.abs(px[None, :] - centre_xy[:, 0:1]) - x_half[:, None], 0.0)
        dy = np.maximum(np.abs(py[None, :] - centre_xy[:, 1:2]) - y_half[:, None], 0.0)
        return (np.hypot(dx, dy) < self.xy_radius[None, :]).any(axis=1)

    def blocks(self, pos: np.ndarray, yaw: float, velocity: np.ndarray, centres: np.ndarray,
               velocities: np.ndarray, radii: np.ndarray, horizon: float = math.inf) -> bool:
        """Whether the straight path at base_link ``velocity`` meets a wall within ``horizon``.

        A cover circle already touching a wall blocks only a velocity that closes in. The
        default horizon is unbounded: the barrier forbids approaching a wall head-on from any
        distance, and walls exist only within the perception's range.

        Args:
            pos: base position in odom [m].
            yaw: base yaw [rad].
            velocity: ``(vx, vy)`` in base_link [m/s], at the present heading.
            centres: ``(n, 2)`` the walls' circles in odom [m].
            velocities: ``(n, 2)`` their velocities in odom [m/s] (a bar may move).
            radii: ``(n,)`` their radii [m] (grown by the safety margin).
            horizon: look-ahead [s].

        """
        if len(radii) == 0 or not np.any(velocity):
            return False
        c, s = math.cos(yaw), math.sin(yaw)
        rot = np.array([[c, -s], [s, c]])
        points = np.asarray(pos, dtype=float)[:2] + self.xy_offset @ rot.T  # (k, 2)
        vel = (rot @ np.asarray(velocity, dtype=float)).reshape(1, 2)
        k, n = len(points), len(radii)
        p = (centres[None, :, :] - points[:, None, :]).reshape(k * n, 2)
        w = np.broadcast_to(np.asarray(velocities, dtype=float), (k, n, 2)).reshape(k * n, 2)
        r = (radii[None, :] + self.xy_radius[:, None]).reshape(k * n)
        t = first_contact_times(vel, p, w, r, horizon)
        return bool(np.isfinite(t[0]))



@dataclass(slots=True)
class _BarMemory:
    """What ``BarWalls.decide`` remembers of one tracked bar (times in s, deficits in m)."""

    average: float
    walled: bool
    first: float
    last: float
    count: int = 1

    def update(self, d: float, t: float) -> None:
        """Take one more deficit ``d`` at time ``t``."""
        self.count += 1
        settling = self.last - self.first < WALL_SETTLE
        if t - self.first < WALL_SETTLE:  # plain mean; a wall once clearly too low
            self.average += (d - self.average) / self.count
            self.walled = self.walled or self.average > WALL_SURE
        else:
            w = min(max(t - self.last, 0.0) / WALL_TAU, 1.0)
            self.average += w * (d - self.average)
            if settling:  # the first decision from the settled mean
                self.walled = self.average > WALL_BAND
            elif self.walled:
                self.walled = self.average > -WALL_BAND
            else:
                self.walled = self.average > WALL_BAND
        self.last = t
