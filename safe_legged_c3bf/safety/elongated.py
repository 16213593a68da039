"""Elongated obstacles (a wall segment, a bench, a flat board) as a row of circles.

One circle of the major semi-axis would close a doorway beside a wall or a path along it.
An ellipse with semi-axes ``a >= b`` lies inside its bounding box ``[-a, a] x [-b, b]`` (in
its own frame, rotated by ``orientation`` from odom x within its plane); cut into ``k``
cells along the major axis, each cell lies inside its circumscribed circle, of radius
``sqrt((a / k)^2 + b^2)`` about the cell's centre. ``k`` is the fewest cells whose circles
stick out at most ``MAX_BULGE`` beyond the minor semi-axis (``a / k <= sqrt((b + MAX_BULGE)^2
- b^2)``), at most ``MAX_CIRCLES``: a wall beside a path or a corridor keeps its width within
4 cm (with 8 circles at most, as before, a 3 m wall 0.2 m thick grew by 0.29 m on each side
and closed a 1.6 m corridor to the A1's body). Obstacles with ``a <= ELONGATION b`` stay one
circle of radius ``a`` (the cover would not be smaller). Units: m, rad; frames: odom, the
obstacle's plane (x-y for VERTICAL, x-z for bars).

An ellipse narrows towards its ends, so each circle only needs to cover the part of the
ellipse inside its cell, not the cell's whole box (``fit="ellipse"``, the default): with
``w(d) = b sqrt(1 - d^2 / a^2)`` the ellipse's half width at ``d`` along the major axis, the
farthest point of that part from the cell's centre ``c`` lies on the boundary, at squared
distance ``(d - c)^2 + w(d)^2``, a convex function of ``d`` (its ``d^2`` coefficient is
``1 - b^2 / a^2 > 0``), so at one of the cell's ends ``d0``, ``d1``: the radius is
``sqrt(max((d0 - c)^2 + w(d0)^2, (d1 - c)^2 + w(d1)^2))``. The end circles shrink the most:
a 3 m wall 0.2 m thick stuck out 4.3 cm beyond each end with box cells and 1.2 cm now, which
is what a doorway between two wall ends gains. ``fit="box"`` covers the bounding box (the
bars' rectangular footprints).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ELONGATION", "MAX_BULGE", "MAX_CIRCLES", "ellipse_cover"]

ELONGATION = 1.5
"""Aspect ratio (major / minor semi-axis) above which an ellipse becomes a row of circles."""
MAX_BULGE = 0.04
"""How far (m) a circle may stick out beyond the ellipse's minor semi-axis."""
MAX_CIRCLES = 32
"""Most circles one obstacle becomes (a longer one gets larger circles, still covering)."""


def ellipse_cover(semi_axes, orientation, max_bulge: float = MAX_BULGE, fit: str = "ellipse",
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Circles covering each ellipse: ``(index, offset, radius)``.

    Args:
        semi_axes: ``(n, 2)`` semi-axes ``(a, b)`` [m] (``a`` along ``orientation``).
        orientation: ``(n,)`` angle [rad] of semi-axis ``a`` from odom x, in the plane.
        max_bulge: how far [m] a circle may stick out beyond the minor semi-axis (> 0).
        fit: ``"ellipse"``: each circle covers the ellipse within its cell; ``"box"``: the
            cell's whole box (a rectangle with these half sizes is covered too).

    Returns:
        ``index`` ``(m,)`` the obstacle of each circle (non-decreasing), ``offset`` ``(m, 2)``
        its centre relative to the ellipse's centre (in-plane, odom axes) [m] and ``radius``
        ``(m,)`` [m]. An obstacle that is not elongated gives one circle, offset 0, radius
        its major semi-axis.

    """
    ax = np.asarray(semi_axes, dtype=float).reshape(-1, 2)
    ang = np.asarray(orientation, dtype=float).reshape(-1)
    if fit not in ("ellipse", "box"):
        raise ValueError(f"fit must be 'ellipse' or 'box', not {fit!r}")
    index, offset, radius = [], [], []
    for i, ((a, b), th) in enumerate(zip(ax.tolist(), ang.tolist(), strict=True)):
        major, minor = max(a, b), min(a, b)
        if major <= ELONGATION * minor:
            index.append(i)
            offset.append((0.0, 0.0))
            radius.append(major)
            continue
        axis = th if a >= b else th + 0.5 * math.pi  # direction of the major axis
        cell = math.sqrt((minor + max_bulge) ** 2 - minor * minor)  # largest half cell
        k = min(math.ceil(major / cell), MAX_CIRCLES)
        half = major / k
        c, s = math.cos(axis), math.sin(axis)
        for j in range(k):
            d = -major + (2 * j + 1) * half
            index.append(i)
            offset.append((d * c, d * s))
            radius.append(_cell_radius(major, minor, d, half) if fit == "ellipse"
                          else math.hypot(half, minor))
    return np.array(index, dtype=np.intp), np.array(offset, dtype=float), np.array(radius)


def _cell_radius(major: float, minor: float, centre: float, half: float) -> float:
    """Radius [m] of the circle about ``centre`` covering the ellipse within its cell.

    The cell is ``[centre - half, centre + half]`` along the major axis; the farthest point
    is at one of its ends (see the module docstring).
    """
    far = 0.0
    for end in (centre - half, centre + half):
        width2 = minor * minor * max(0.0, 1.0 - (end / major) ** 2)
        far = max(far, (end - centre) ** 2 + width2)
    return math.sqrt(far)
