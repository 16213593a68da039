"""Free headings narrower than the steering's grid: doorways between obstacles (issue #19).

The cone steering (``cone_steering``) tests headings on a grid of ``heading_step`` (5 deg)
round the reference heading. A free window narrower than one step can fall between two grid
headings, both blocked, and is never seen: the doorway of ``quadruped_gap``, as the sensors'
wall pieces leave it (8.7 cm of room for the cover's centre, 1.7 deg seen from 3 m), was not
found, and the steering took the robot round the left wall.

A static circle of radius ``r`` (obstacle plus robot) at ``p`` from the robot blocks exactly
the headings within ``asin(r / |p|)`` of its direction (within reach of the horizon), so the
edges of every free window between static obstacles are the circles' tangent headings. The
steering adds, to the grid, the headings ``TANGENT_MARGIN`` outside each tangent and tests
them with the same velocity-obstacle test as the grid (``blocked_headings``): a window between
two circles is then seen, whatever its width. Only static obstacles give tangents (a mover's
cone in heading depends on its speed as well); the grid covers the movers as before.

A free run of candidates narrower than twice the steering's edge margin is aimed at its middle
(the heading equally far from the cones on both sides), not ``edge`` past its first heading,
which would be in the cone beyond it, and only when its middle heading is free with every
circle grown by ``MIN_ROOM / 2`` (the window leaves at least ``MIN_ROOM`` across); else the next
run is taken. Units: rad, m; headings in odom (REP-103).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "MIN_ROOM", "TANGENT_MARGIN", "aim_in_run", "first_free_run", "free_runs", "tangent_offsets",
    "with_tangents",
]

TANGENT_MARGIN = math.radians(0.25)
"""Angle [rad] outside a circle's tangent heading at which a candidate heading is tested."""
MIN_ROOM = 0.04
"""Least room [m] across a narrow window, for the cover's centre, for it to be aimed at: twice
the A1's p99 sideways drift from the commanded motion in 1 s (2.0 cm, doc/evaluation.md,
"velocity tracking"). The margins already hold the drift off the obstacles; this is the
heading's precision: a window 1.6 cm across seen from 1 m (0.9 deg) was aimed at and the
biped, having walked into the passage, stood in it (test/test_stall_detour.py standoff)."""


def tangent_offsets(base: float, p: np.ndarray, r: np.ndarray, max_turn: float,
                    reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Offsets [rad] from ``base`` of the headings just outside each circle's tangents.

    Args:
        base: Heading [rad] the offsets are measured from (odom).
        p: ``(n, 2)`` circle centres minus the robot position [m].
        r: ``(n,)`` circle radii, obstacle plus robot [m].
        max_turn: Largest offset kept [rad].
        reach: Circles farther than this [m] (edge to robot) are left out: nothing there
            blocks a heading within the horizon.

    Returns:
        ``(left, right)``: offsets in ``(0, max_turn]`` to the left (counter-clockwise) and
        to the right (as positive magnitudes), each sorted ascending.

    """
    d = np.hypot(p[:, 0], p[:, 1])
    keep = (d > r) & (d - r <= reach)
    if not keep.any():
        return np.empty(0), np.empty(0)
    direction = np.arctan2(p[keep, 1], p[keep, 0])
    half = np.arcsin(r[keep] / d[keep]) + TANGENT_MARGIN
    edges = np.concatenate([direction + half, direction - half]) - base
    edges = np.remainder(edges + math.pi, math.tau) - math.pi
    left = edges[(edges > 0.0) & (edges <= max_turn)]
    right = -edges[(edges < 0.0) & (edges >= -max_turn)]
    return np.sort(left), np.sort(right)


def with_tangents(grid: np.ndarray, tangents: np.ndarray) -> np.ndarray:
    """The grid's offsets [rad] and the tangent offsets, sorted ascending."""
    return np.sort(np.concatenate([grid, tangents]))


def free_runs(free: np.ndarray, offsets: np.ndarray) -> list[tuple[float, float]]:
    """``(first, last)`` offsets [rad] of each run of free candidates, nearest first.

    ``offsets`` ascending, ``free`` the test of each; a run ends before the next blocked
    candidate (or at the last candidate).
    """
    edges = np.diff(np.concatenate([[0], free.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(offsets[a]), float(offsets[b])) for a, b in zip(starts, ends, strict=True)]


def first_free_run(free: np.ndarray, offsets: np.ndarray) -> tuple[float, float] | None:
    """The first of :func:`free_runs`; None if no candidate is free."""
    runs = free_runs(free, offsets)
    return runs[0] if runs else None


def aim_in_run(first: float, last: float, edge: float) -> float:
    """The offset [rad] aimed at in a free run: ``edge`` past its first heading, or its middle.

    The middle when the run is narrower than ``2 edge``: equally far from the cones on both
    sides.
    """
    return min(first + edge, 0.5 * (first + last))
