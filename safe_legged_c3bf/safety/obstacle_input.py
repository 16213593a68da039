"""Obstacles as the safety filter receives them, and their conversion to C3BF circles.

Frames and units: odom, m, m/s. A VERTICAL obstacle is an ellipse in x-y (extruded along z);
a HORIZONTAL one an ellipse in x-z extruded along odom y (a bar across the path).

An :class:`ObstacleSet` holds one obstacle list as validated arrays: it is built (and checked)
once when a list arrives, and :func:`to_c3bf_obstacles` turns it into circles every cycle
with a few vectorised operations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from safe_legged_c3bf.c3bf import InvalidInputError, Obstacles, Plane
from safe_legged_c3bf.c3bf.domain import MAX_MAGNITUDE
from safe_legged_c3bf.safety.bar_walls import WALL_BULGE, BarWalls, bar_extents
from safe_legged_c3bf.safety.elongated import ELONGATION, ellipse_cover

_VERTICAL = frozenset({Plane.VERTICAL})
_NONE = np.zeros(0, dtype=bool)
_NONE.setflags(write=False)


@dataclass(frozen=True)
class ObstacleInput:
    """One obstacle from /obstacles.

    Attributes:
        id: identifier (may be empty).
        plane: 0 = VERTICAL, 1 = HORIZONTAL (Obstacle.msg constants).
        center: (3,) centre in odom (m).
        velocity: (3,) velocity in odom (m/s).
        semi_axes: (2,) ellipse semi-axes (m).
        extent: length along the extrusion axis (m): z for VERTICAL, y for HORIZONTAL.
        orientation: angle of semi-axis a from odom x within the plane (rad).

    """

    id: str
    plane: int
    center: np.ndarray
    velocity: np.ndarray
    semi_axes: np.ndarray
    extent: float
    orientation: float = 0.0

    def is_valid(self) -> bool:
        """True when every number is finite, sizes are positive and the plane is known."""
        return bool(
            self.plane in (0, 1)
            and np.all(np.isfinite(self.center))
            and np.all(np.isfinite(self.velocity))
            and np.all(np.isfinite(self.semi_axes))
            and np.all(np.asarray(self.semi_axes) > 0)
            and np.isfinite(self.extent)
            and np.isfinite(self.orientation)
        )


@dataclass(frozen=True, eq=False)
class ObstacleSet:
    """A validated obstacle list as read-only arrays (see :meth:`from_arrays`).

    Attributes:
        ids: identifiers, in order.
        plane: ``(n,)`` 0 = VERTICAL, 1 = HORIZONTAL.
        center: ``(n, 3)`` centres in odom (m).
        velocity: ``(n, 3)`` velocities in odom (m/s).
        size: ``(n,)`` largest semi-axis (m): the radius of the circle around the ellipse.
        extent: ``(n,)`` length along the extrusion axis (m).
        all_vertical: every obstacle is VERTICAL.
        semi_axes: ``(n, 2)`` the ellipse semi-axes (m).
        orientation: ``(n,)`` angle of semi-axis a from odom x in the plane (rad).
        all_round: no obstacle is elongated (``elongated.ELONGATION``): one circle each.

    """

    ids: tuple[str, ...]
    plane: np.ndarray
    center: np.ndarray
    velocity: np.ndarray
    size: np.ndarray
    extent: np.ndarray
    all_vertical: bool
    semi_axes: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    orientation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    all_round: bool = True
    _radii: dict = field(default_factory=dict, repr=False)  # radii, tie-breaks per parameters

    @cached_property
    def cover(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(index, offset, radius)`` of the circles covering every obstacle.

        ``elongated.ellipse_cover``: one circle of the largest semi-axis when round.
        """
        return ellipse_cover(self.semi_axes, self.orientation)

    @cached_property
    def bar_footprints(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(x_half, index, offset, radius)``: each bar's x-y footprint and its circles.

        ``x_half`` ``(n,)`` [m]: the x half-extent of every obstacle's ellipse (used for the
        bars: their footprint is ``x_half`` by ``extent / 2`` about the centre, odom axes);
        the circles (``index``, ``offset``, ``radius`` as :attr:`cover`) cover the footprints
        of the HORIZONTAL obstacles only, for when a bar is walled (``bar_walls``). Computed
        once per obstacle list, not every cycle.
        """
        x_half, _ = bar_extents(self.semi_axes, self.orientation)
        bars = np.flatnonzero(self.plane == int(Plane.HORIZONTAL))
        y_half = 0.5 * self.extent[bars]
        f_index, f_offset, f_radius = ellipse_cover(
            np.column_stack([x_half[bars], y_half]), np.zeros(bars.size), WALL_BULGE, fit="box",
        )
        # A footprint not elongated enough for a row is one circle of its larger half-size,
        # which covers the ellipse but not the rectangle's corners: grow it to the half-diagonal.
        single = (np.bincount(f_index, minlength=bars.size) == 1)[f_index]
        f_radius = np.where(single, np.hypot(x_half[bars], y_half)[f_index], f_radius)
        return x_half, bars[f_index], f_offset.reshape(-1, 2), f_radius

    @cached_property
    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        """``(n, 2)`` x-y centres and x-y velocities (read-only copies)."""
        c, v = self.center[:, :2].copy(), self.velocity[:, :2].copy()
        c.setflags(write=False)
        v.setflags(write=False)
        return c, v

    def tie_breaks(self, tie_break: float, full_speed: float = 0.0) -> np.ndarray:
        """``(n,)`` each obstacle's tie-break [m] (cached, read-only).

        ``tie_break`` in full for every obstacle when ``full_speed`` [m/s] is 0; otherwise in
        proportion to the obstacle's x-y speed up to ``full_speed``, in full from there on.
        """
        key = ("tie_break", tie_break, full_speed)
        tb = self._radii.get(key)
        if tb is None:
            if full_speed > 0.0:
                speed = np.hypot(self.velocity[:, 0], self.velocity[:, 1])
                tb = tie_break * np.minimum(speed / full_speed, 1.0)
            else:
                tb = np.full(len(self.ids), float(tie_break))
            tb.setflags(write=False)
            self._radii[key] = tb
        return tb

    def vertical_radius(self, robot_width: float, safety_margin: float, tie_break: float,
                        full_speed: float = 0.0):
        """``size + robot_width / 2 + safety_margin`` + each one's tie-break (cached, read-only).

        The tie-break as :meth:`tie_breaks` gives it.
        """
        key = (robot_width, safety_margin, tie_break, full_speed)
        r = self._radii.get(key)
        if r is None:
            r = self.size + 0.5 * robot_width + safety_margin + self.tie_breaks(
                tie_break, full_speed)
            if not np.isfinite(r).all():
                raise InvalidInputError("inflated obstacle radius overflowed")
            r.setflags(write=False)
            self._radii[key] = r
        return r

    @classmethod
    def from_arrays(
        cls, ids, plane, center, velocity, semi_axes, extent, orientation=None
    ) -> ObstacleSet:
        """Validate and store one obstacle list.

        Args:
            ids: ``n`` identifiers.
            plane: ``(n,)`` plane values.
            center: ``(n, 3)`` centres (m).
            velocity: ``(n, 3)`` velocities (m/s).
            semi_axes: ``(n, 2)`` ellipse semi-axes (m).
            extent: ``(n,)`` extents (m).
            orientation: ``(n,)`` angles of semi-axis a (rad); None: 0.

        Raises:
            InvalidInputError: wrong shapes, a non-finite number, a semi-axis <= 0, an
                unknown plane (the rules of :meth:`ObstacleInput.is_valid`), or a centre,
                velocity or semi-axis beyond the C3BF library's domain (1e9).

        """
        ids = tuple(str(i) for i in ids)
        n = len(ids)
        try:
            pl = np.asarray(plane, dtype=float).reshape(n)
            c = np.array(center, dtype=float).reshape(n, 3)
            v = np.array(velocity, dtype=float).reshape(n, 3)
            ax = np.asarray(semi_axes, dtype=float).reshape(n, 2)
            ext = np.array(extent, dtype=float).reshape(n)
            ori = np.zeros(n) if orientation is None else np.array(
                orientation, dtype=float).reshape(n)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"obstacle arrays do not match {n} ids: {exc}") from exc
        ok = (
            ((pl == 0) | (pl == 1)).all()
            and np.isfinite(c).all()
            and np.isfinite(v).all()
            and np.isfinite(ax).all()
            and (ax > 0).all()
            and np.isfinite(ext).all()
            and np.isfinite(ori).all()
        )
        if not ok:
            raise InvalidInputError("obstacle with NaN/Inf, a semi-axis <= 0 or an unknown plane")
        largest = max(np.abs(c).max(initial=0.0), np.abs(v).max(initial=0.0), ax.max(initial=0.0))
        if largest > MAX_MAGNITUDE:
            raise InvalidInputError(
                f"obstacle number {largest:.3g} beyond the C3BF library's domain "
                f"(|x| <= {MAX_MAGNITUDE:g} m, m/s)"
            )
        arrays = (pl.astype(np.intp), c, v, ax.max(axis=1), ext)
        for arr in (*arrays, ax, ori):
            arr.setflags(write=False)
        round_ = bool((ax.max(axis=1) <= ELONGATION * ax.min(axis=1)).all())
        return cls(ids, *arrays, all_vertical=bool((pl == int(Plane.VERTICAL)).all()),
                   semi_axes=ax, orientation=ori, all_round=round_)

    @classmethod
    def from_inputs(cls, obstacles: Sequence[ObstacleInput]) -> ObstacleSet:
        """Validate and store a list of :class:`ObstacleInput`."""
        return cls.from_arrays(
            [o.id for o in obstacles],
            [o.plane for o in obstacles],
            [o.center for o in obstacles],
            [o.velocity for o in obstacles],
            [o.semi_axes for o in obstacles],
            [o.extent for o in obstacles],
            [o.orientation for o in obstacles],
        )

    def __len__(self) -> int:
        """Number of obstacles."""
        return len(self.ids)


def to_c3bf_obstacles(*args, **kwargs) -> tuple[Obstacles, list[str]]:
    """:func:`to_c3bf_obstacles_walled` without the mask of walled circles."""
    circles, ids, _ = to_c3bf_obstacles_walled(*args, **kwargs)
    return circles, ids


def to_c3bf_obstacles_walled(
    obstacles: ObstacleSet | Sequence[ObstacleInput],
    dt_predict: float,
    robot_y: float,
    robot_width: float,
    robot_height: float,
    safety_margin: float,
    horizontal_y_margin: float,
    robot_yaw: float = 0.0,
    tie_break: float = 0.0,
    bar_half_width: float | None = None,
    walls: BarWalls | None = None,
    robot_x: float = 0.0,
    t: float | None = None,
    tie_break_speed: float = 0.0,
) -> tuple[Obstacles, list[str], np.ndarray]:
    """Inflated circles for the C3BF filter, predicted ``dt_predict`` s ahead.

    A horizontal bar is kept only while the robot's y lies within its extent along y, grown
    by half the robot width and ``horizontal_y_margin``: beside the bar there is nothing to
    duck under (``bar_half_width`` [m], default ``robot_width / 2``). Returns the circles and
    the ids of the obstacles kept, in order. ``robot_width`` and ``robot_height`` are the
    diameters [m] vertical and horizontal circles grow by (0 for the whole-body filter, which
    grows them by each body point's radius).

    Elongated obstacles become a row of circles (``elongated``), each with the obstacle's id.

    With ``walls`` (the whole body), a bar the body cannot duck under becomes a VERTICAL
    obstacle, its x-y footprint (``bar_walls``), unless the robot (at ``robot_x``,
    ``robot_y``, ``robot_yaw``) is already under it; the third value returned is the mask of
    the circles that came from such walls. ``t`` [s]: the time of the decision
    (``BarWalls.decide``; None: the rule at this instant, no memory).

    Symmetry breaking: dead ahead of a unicycle the barrier's sensitivity to steering is
    exactly zero, so a head-on obstacle can only be braked for (and a faster mover cannot be
    escaped). Each vertical circle is therefore moved ``tie_break`` m to the robot's right and
    grown by ``tie_break``: the new circle encloses the old one (still safe), and the robot
    consistently passes obstacles on their left. With ``tie_break_speed`` > 0 [m/s] an
    obstacle gets the tie-break in proportion to its x-y speed, in full from that speed on
    (:meth:`ObstacleSet.tie_breaks`): for when something else picks the side of static
    obstacles (the whole body's cone steering), so that it is a margin for movers only.

    ``obstacles`` is best an :class:`ObstacleSet` (validated once); a list of
    :class:`ObstacleInput` is validated on every call. Raises :class:`InvalidInputError` on
    invalid obstacles or if the prediction overflows.
    """
    if not isinstance(obstacles, ObstacleSet):
        obstacles = ObstacleSet.from_inputs(obstacles)
    if len(obstacles) == 0:
        return Obstacles.empty(), [], _NONE
    plane = obstacles.plane
    ids = list(obstacles.ids)
    if obstacles.all_vertical and obstacles.all_round:  # pillars, people: fewer operations
        # (x, y) moved each one's tie-break to the robot's right (sin yaw, -cos yaw).
        c2, velocity = obstacles.xy
        tb = obstacles.tie_breaks(tie_break, tie_break_speed)
        center = (c2 + dt_predict * velocity) + tb[:, None] * np.array(
            [math.sin(robot_yaw), -math.cos(robot_yaw)]
        )
        radius = obstacles.vertical_radius(robot_width, safety_margin, tie_break,
                                           tie_break_speed)
        if not math.isfinite(center.sum()):  # NaN/Inf anywhere (or an absurd overflow)
            raise InvalidInputError("obstacle prediction overflowed")
        return (Obstacles.from_validated(center, velocity, radius, plane, _VERTICAL), ids,
                np.zeros(len(ids), dtype=bool))
    c = obstacles.center + dt_predict * obstacles.velocity
    vel = obstacles.velocity
    vertical = plane == int(Plane.VERTICAL)
    # Every obstacle as its covering circles (elongated ones: a row, ``elongated``).
    index, offset, cover_r = obstacles.cover
    walled = np.zeros(len(obstacles), dtype=bool)
    if walls is not None and not vertical.all():
        walled = _walled(obstacles, c, vertical, walls, safety_margin, robot_height,
                         (robot_x, robot_y), robot_yaw, t)
        if walled.any():
            vertical = vertical | walled
            index, offset, cover_r = _with_footprints(obstacles, walled, index, offset, cover_r)
    half_width = 0.5 * robot_width if bar_half_width is None else bar_half_width
    half_span = 0.5 * obstacles.extent + half_width + horizontal_y_margin
    keep = vertical | (np.abs(robot_y - c[:, 1]) <= half_span)
    rows = keep[index]
    oi, off, cover_r = index[rows], offset[rows], cover_r[rows]
    if oi.size == 0:
        return Obstacles.empty(), [], _NONE
    v = vertical[oi]
    tb = np.where(v, obstacles.tie_breaks(tie_break, tie_break_speed)[oi], 0.0)
    # Vertical: (x, y) moved the tie-break to the robot's right; bars: (x, z) (see above).
    center = np.empty((oi.size, 2))
    center[:, 0] = c[oi, 0] + off[:, 0] + tb * math.sin(robot_yaw)
    center[:, 1] = np.where(v, c[oi, 1] - tb * math.cos(robot_yaw), c[oi, 2]) + off[:, 1]
    velocity = np.empty((oi.size, 2))
    velocity[:, 0] = vel[oi, 0]
    velocity[:, 1] = np.where(v, vel[oi, 1], vel[oi, 2])
    radius = np.where(
        v,
        cover_r + 0.5 * robot_width + safety_margin + tb,
        cover_r + 0.5 * robot_height + safety_margin,
    )
    plane = np.where(v, int(Plane.VERTICAL), int(Plane.HORIZONTAL))
    ids = [ids[i] for i in oi.tolist()]
    if not (np.isfinite(center).all() and np.isfinite(radius).all()):
        raise InvalidInputError("obstacle prediction overflowed")
    return Obstacles.from_validated(center, velocity, radius, plane), ids, walled[oi]


def _walled(obstacles: ObstacleSet, c: np.ndarray, vertical: np.ndarray, walls: BarWalls,
            safety_margin: float, robot_height: float, robot_xy: tuple[float, float],
            robot_yaw: float, t: float | None) -> np.ndarray:
    """``(n,)`` mask of the bars to hand over as walls (``bar_walls``); ``c``: predicted centres."""
    index, offset, cover_r = obstacles.cover
    bar = ~vertical[index]
    grown = cover_r[bar] + 0.5 * robot_height + safety_margin + walls.margin
    deficit = walls.deficit(c[index[bar], 2] + offset[bar, 1], grown, index[bar],
                            len(obstacles))
    far = walls.out_of_range(np.asarray(robot_xy), c[:, :2], obstacles.bar_footprints[0],
                             0.5 * obstacles.extent)
    deficit[far & ~vertical] = np.nan  # bars not judged yet: neither walled nor remembered
    walled = walls.decide(obstacles.ids, deficit, t)
    if walled.any():
        cand = np.flatnonzero(walled)
        x_half = obstacles.bar_footprints[0][cand]
        under = walls.under(np.asarray(robot_xy), robot_yaw, c[cand, :2], x_half,
                            0.5 * obstacles.extent[cand])
        walled[cand[under]] = False
    return walled


def _with_footprints(obstacles: ObstacleSet, walled: np.ndarray, index: np.ndarray,
                     offset: np.ndarray, radius: np.ndarray):  # noqa: ANN202
    """The cover with each walled bar's circles replaced by its footprint's, by obstacle.

    The footprint circles are ``ObstacleSet.bar_footprints`` (computed once per list).
    """
    _, f_index, f_offset, f_radius = obstacles.bar_footprints
    take = walled[f_index]
    rest = ~walled[index]
    index = np.concatenate([index[rest], f_index[take]])
    order = np.argsort(index, kind="stable")
    return (index[order], np.concatenate([offset[rest], f_offset[take]])[order],
            np.concatenate([radius[rest], f_radius[take]])[order])
