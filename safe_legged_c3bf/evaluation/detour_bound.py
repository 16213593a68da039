"""The detour no controller could avoid: a lower bound on a run's time-to-goal overhead.

The time-to-goal overhead (``metrics.attach_overhead``) compares a run with the same
scenario's obstacle-free run, so it counts the detour round the obstacles as well as the
filter's caution. This module bounds the first part from below, from the scenario alone:

* the robot is a disc of its trunk's inscribed radius (``unsurvivable.TRUNK_RADIUS``, the
  smallest body it could have);
* each static vertical obstacle is grown by that radius to the ellipse of semi-axes
  ``(a + r, b + r)`` (inside the true grown shape, the Minkowski sum: its support function
  is at most the sum's) and replaced by a polygon inscribed in that ellipse (inside again);
* movers, bars and the gait are left out (they only add time);
* the shortest start-goal path round those convex polygons is exact on their visibility
  graph (the polygons' vertices, the start and the goal; an edge where the segment does not
  cross a polygon's interior), found with scipy's Dijkstra.

Every simplification makes the path shorter, so ``(shortest - straight) / cruise`` is a
lower bound on the extra time [s] any robot walking at most the planner's cruise speed
needs. Units: m, s; odom frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from safe_legged_c3bf.evaluation.random_checks import moving
from safe_legged_c3bf.evaluation.unsurvivable import TRUNK_RADIUS
from safe_legged_c3bf.planning.reference_planner import PlannerConfig

if TYPE_CHECKING:
    from safe_legged_c3bf.sim.scenario import ObstacleConfig, Scenario

#: Vertices of each obstacle's inscribed polygon.
POLYGON_SIDES = 32
#: Length (m) by which a segment may run inside a polygon and still count as outside it (a
#: segment along an edge or through a shared vertex, up to rounding).
TOLERANCE = 1e-9


@dataclass(frozen=True)
class DetourBound:
    """A scenario's unavoidable detour.

    Attributes:
        straight: start-goal distance [m].
        shortest: shortest path round the grown static obstacles [m] (``inf`` when the goal
            cannot be reached round them).
        cruise: the planner's cruise speed [m/s] (the scenario's, else the planner's
            default ``max_vx``).
        extra_time: ``(shortest - straight) / cruise`` [s], the least overhead.

    """

    straight: float
    shortest: float
    cruise: float
    extra_time: float


def inscribed_polygon(obs: ObstacleConfig, radius: float, sides: int = POLYGON_SIDES
                      ) -> np.ndarray:
    """``(sides, 2)`` counter-clockwise vertices on the ellipse ``(a + radius, b + radius)``.

    The ellipse is the vertical obstacle's at its start position (odom, m).
    """
    a, b = obs.semi_axes
    u = np.linspace(0.0, 2.0 * math.pi, sides, endpoint=False)
    x, y = (a + radius) * np.cos(u), (b + radius) * np.sin(u)
    c, s = math.cos(obs.orientation), math.sin(obs.orientation)
    return np.column_stack([obs.position[0] + c * x - s * y, obs.position[1] + s * x + c * y])


def crosses_interior(p: np.ndarray, q: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """``(m,)`` bool: segment ``p[k]``-``q[k]`` runs through the convex ``polygon``'s interior.

    Clips each segment by every edge's inner half-plane (Cyrus-Beck); a segment crosses the
    interior when a piece longer than ``TOLERANCE`` stays strictly inside every half-plane.
    ``p``, ``q``: ``(m, 2)`` end points; ``polygon``: ``(n, 2)`` counter-clockwise vertices.
    """
    d = q - p
    length = np.hypot(d[:, 0], d[:, 1])
    edges = np.roll(polygon, -1, axis=0) - polygon
    normals = np.column_stack([-edges[:, 1], edges[:, 0]])  # inward for counter-clockwise
    normals /= np.hypot(normals[:, 0], normals[:, 1])[:, None]
    # p's depth inside each edge [m], and its change per metre along the segment: (m, n)
    depth = (p @ normals.T) - np.einsum("ij,ij->i", polygon, normals)[None, :]
    rate = (d @ normals.T) / np.maximum(length, 1e-15)[:, None]
    # Strictly inside edge j where depth + rate * s > TOLERANCE, for s in [0, length].
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (TOLERANCE - depth) / rate
    parallel = np.abs(rate) < 1e-15
    lo = np.where(rate > 0.0, s, -np.inf).max(axis=1, initial=0.0)
    hi = np.minimum(np.where(rate < 0.0, s, np.inf).min(axis=1), length)
    outside_a_parallel_edge = (parallel & (depth <= TOLERANCE)).any(axis=1)
    return (hi - lo > TOLERANCE) & ~outside_a_parallel_edge & (length > 0.0)


def shortest_path_length(start: np.ndarray, goal: np.ndarray, polygons: list[np.ndarray]
                         ) -> float:
    """Length [m] of the shortest start-goal path outside the convex ``polygons``' interiors.

    ``inf`` when there is none. Exact on the visibility graph of the polygons' vertices.
    """
    nodes = np.vstack([start[None, :], goal[None, :], *polygons])
    i, j = np.triu_indices(len(nodes), k=1)
    free = np.ones(len(i), dtype=bool)
    for poly in polygons:
        free &= ~crosses_interior(nodes[i], nodes[j], poly)
    length = np.hypot(*(nodes[j] - nodes[i]).T)
    # csgraph reads a zero as no edge: nodes at one point are joined at 1e-12 m.
    graph = csr_matrix((np.maximum(length[free], 1e-12), (i[free], j[free])),
                       shape=(len(nodes), len(nodes)))
    return float(dijkstra(graph, directed=False, indices=0)[1])


def static_obstacles(scenario: Scenario) -> list[ObstacleConfig]:
    """The scenario's vertical obstacles that never move."""
    return [o for o in scenario.obstacles if o.plane == "vertical" and not moving(o)]


def detour_bound(scenario: Scenario, sides: int = POLYGON_SIDES) -> DetourBound:
    """The least detour of ``scenario`` (see the module docstring).

    A static obstacle whose grown polygon holds the start or the goal is left out (the
    robot starts or ends touching its margin; leaving it out keeps the bound a bound).
    """
    start = np.asarray(scenario.robot.position[:2], dtype=float)
    goal = np.asarray(scenario.goal.position[:2], dtype=float)
    radius = TRUNK_RADIUS[scenario.robot.kind]
    polygons = []
    for obs in static_obstacles(scenario):
        poly = inscribed_polygon(obs, radius, sides)
        if not (_inside(start, poly) or _inside(goal, poly)):
            polygons.append(poly)
    straight = float(np.hypot(*(goal - start)))
    shortest = shortest_path_length(start, goal, polygons)
    cruise = float(scenario.planner.speed or PlannerConfig().max_vx)
    return DetourBound(straight, shortest, cruise, (shortest - straight) / cruise)


def _inside(point: np.ndarray, polygon: np.ndarray) -> bool:
    """True when ``point`` lies in the convex counter-clockwise ``polygon`` (edges included)."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    rel = point - polygon
    return bool(np.all(edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] >= 0.0))
