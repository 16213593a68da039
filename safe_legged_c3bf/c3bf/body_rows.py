"""Whole-body constraint rows: one C3BF row per (body point, obstacle) pair, and back.

:func:`body_rows` pairs every obstacle with every body point of its plane (x-y circles with
VERTICAL obstacles, x-z circles with HORIZONTAL bars) and returns, per row, the point's
kinematics (``offset_kinematics``) and the obstacle grown by the point's radius: the filter
then builds and solves the rows exactly as for one body point (``rows``, ``inside``, the QP),
only with row-wise kinematics. :func:`per_obstacle` folds a :class:`~.result.FilterResult`
over rows back to one entry per obstacle, the worst row of each (least ``h``, constraint and
clearance; greatest slack; active if any row is).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .body import RobotBody
from .errors import InvalidInputError
from .geometry import Obstacles, Plane
from .models import PointKinematics, RobotModel
from .offset_kinematics import offset_point_kinematics
from .result import FilterResult

__all__ = ["BodyRows", "body_rows", "per_obstacle"]


class BodyRows(NamedTuple):
    """The (point, obstacle) pairs of one filter call, ordered by obstacle."""

    kin: PointKinematics
    """Row-wise body-point kinematics, arrays ``(n_rows, 3)`` and ``(n_rows, 3, m)``."""
    obstacles: Obstacles
    """Row-wise obstacles: centre, velocity and plane of the obstacle, radius grown by the
    point's radius [m]."""
    obstacle: np.ndarray
    """``(n_rows,)`` index of each row's obstacle (non-decreasing)."""
    point: np.ndarray
    """``(n_rows,)`` index of each row's body point in ``RobotBody.points``."""


def body_rows(model: RobotModel, x, yaw, body: RobotBody, obs: Obstacles) -> BodyRows:
    """Pair every obstacle with the body points of its plane (see module docstring).

    Raises:
        InvalidInputError: an obstacle's plane has no body point (it would be ignored).

    """
    offsets, radii, planes = body.arrays
    match = planes[None, :] == obs.plane[:, None]  # (n, k)
    uncovered = ~match.any(axis=1)
    if uncovered.any():
        plane = Plane(int(obs.plane[np.flatnonzero(uncovered)[0]])).name
        raise InvalidInputError(f"body '{body.name}' has no point for {plane} obstacles")
    oi, pk = np.nonzero(match)
    kin = offset_point_kinematics(model, x, offsets, yaw)
    kin = PointKinematics(*(a[pk] for a in kin))
    rows = Obstacles.from_validated(
        obs.center[oi], obs.velocity[oi], obs.radius[oi] + radii[pk], obs.plane[oi],
        obs.planes_present,
    )
    return BodyRows(kin, rows, oi, pk)


def per_obstacle(res: FilterResult, rows: BodyRows, n: int) -> FilterResult:
    """``res`` (one entry per row) folded to one entry per obstacle (``n`` obstacles).

    Arrays of another length (a FAILSAFE before the rows were built) become zeros of ``n``.
    ``res.point`` gets, per obstacle, the body point of its row of least clearance.
    """
    m = len(rows.obstacle)
    if n == 0 or len(res.h) != m or len(res.clearance) != m:
        zeros = np.zeros(n)
        res.h, res.constraint, res.slack, res.clearance = zeros, zeros, zeros, zeros
        res.active, res.point = np.zeros(n, dtype=bool), np.full(n, -1)
        return res
    ob = rows.obstacle
    starts = np.concatenate(([0], np.flatnonzero(ob[1:] != ob[:-1]) + 1))  # (np.r_ is slow)
    # Rows sorted by obstacle, then clearance (stable): each group's first is its nearest.
    nearest = np.lexsort((res.clearance, rows.obstacle))[starts]
    res.point = rows.point[nearest]
    res.h = np.minimum.reduceat(res.h, starts)
    res.constraint = np.minimum.reduceat(res.constraint, starts)
    res.slack = np.maximum.reduceat(res.slack, starts)
    res.active = np.logical_or.reduceat(res.active, starts)
    res.clearance = np.minimum.reduceat(res.clearance, starts)
    return res
