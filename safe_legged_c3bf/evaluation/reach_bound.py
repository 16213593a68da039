"""The least time to the goal with the movers' scripts known: a clairvoyant lower bound.

``detour_bound`` leaves the movers out. This module keeps them: the earliest time a robot
that knew every script in advance could stand within the goal tolerance, walking at most
the planner's cruise speed in any direction (no acceleration limit, no turning), waiting
where it likes, being only its trunk's inscribed disc. Any controller needs at least that
long; the same search without obstacles gives the straight walk's time, and their
difference the least overhead a run could have had.

The search is Dijkstra's earliest arrival on a grid of ``CELL`` with 16 neighbours per cell
(edge lengths exact; a path on it is at most 2.7 % longer than the straight line it
follows) and waiting allowed, over an occupancy sampled every ``STEP``. The approximations
keep it a lower bound up to that 2.7 % (units m, s; odom frame):

* a cell is occupied at a sample only when its whole square lies inside an obstacle grown
  by the trunk's radius (static ones as ``detour_bound`` grows them; a mover as the disc of
  its smaller semi-axis plus that radius, shrunk by what it moves in half a step);
* the robot is checked only where it arrives, at the sample nearest its arrival (a knight's
  move may pass a blocked cell it jumps unchecked);
* bars are left out.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from safe_legged_c3bf.evaluation.random_checks import moving, scripted_centres
from safe_legged_c3bf.evaluation.unsurvivable import TRUNK_RADIUS
from safe_legged_c3bf.planning.reference_planner import PlannerConfig

if TYPE_CHECKING:
    from safe_legged_c3bf.sim.scenario import ObstacleConfig, Scenario

#: Grid cell [m] and occupancy sampling step [s].
CELL = 0.05
STEP = 0.1
#: Room [m] around the start, the goal and the obstacles' paths.
BORDER = 1.5
#: Neighbour offsets (cells): the 8 nearest and the 8 knight's moves.
MOVES = [(di, dj) for di in range(-2, 3) for dj in range(-2, 3)
         if (di, dj) != (0, 0) and math.gcd(abs(di), abs(dj)) == 1]


@dataclass(frozen=True)
class ReachBound:
    """A scenario's least times [s] (``inf``: the goal not reached within its duration).

    Attributes:
        with_obstacles: earliest arrival within the goal tolerance, obstacles known.
        free: the same without obstacles.
        extra_time: ``with_obstacles - free``, the least overhead.

    """

    with_obstacles: float
    free: float
    extra_time: float


class _Grid:
    """Cell centres of the rectangle the search runs on."""

    def __init__(self, points: np.ndarray) -> None:
        lo, hi = points.min(axis=0) - BORDER, points.max(axis=0) + BORDER
        self.x, self.y = np.meshgrid(np.arange(lo[0], hi[0] + CELL, CELL),
                                     np.arange(lo[1], hi[1] + CELL, CELL), indexing="ij")

    def cell(self, point: np.ndarray) -> tuple[int, int]:
        """The cell whose centre is nearest ``point``."""
        return (int(round((point[0] - self.x[0, 0]) / CELL)),
                int(round((point[1] - self.y[0, 0]) / CELL)))

    def near(self, point: np.ndarray, radius: float) -> np.ndarray:
        """Cells whose centre lies within ``radius`` of ``point``."""
        return np.hypot(self.x - point[0], self.y - point[1]) <= radius

    def inside_ellipse(self, centre, a: float, b: float, angle: float) -> np.ndarray:
        """Cells whose whole square lies inside the ellipse (semi-axes ``a``, ``b``).

        Both are convex, so a square lies inside when its four corners do.
        """
        if a <= 0.0 or b <= 0.0:
            return np.zeros_like(self.x, dtype=bool)
        c, s = math.cos(angle), math.sin(angle)
        inside = np.ones_like(self.x, dtype=bool)
        for ox in (-0.5 * CELL, 0.5 * CELL):
            for oy in (-0.5 * CELL, 0.5 * CELL):
                dx, dy = self.x + ox - centre[0], self.y + oy - centre[1]
                inside &= ((c * dx + s * dy) / a) ** 2 + ((-s * dx + c * dy) / b) ** 2 <= 1.0
        return inside


def occupancy(grid: _Grid, obstacles: list[ObstacleConfig], times: np.ndarray,
              radius: float, paths: list[np.ndarray | None]) -> np.ndarray:
    """``(len(times),) + grid shape`` bool: cells certainly inside a grown obstacle.

    ``paths``: per obstacle, its centres at ``times``, None if static.
    """
    static = np.zeros_like(grid.x, dtype=bool)
    samples = len(times)
    out = np.empty((samples,) + grid.x.shape, dtype=bool)
    movers = []
    for obs, centres in zip(obstacles, paths, strict=True):
        a, b = obs.semi_axes
        if centres is not None:
            travel = np.hypot(*np.diff(centres, axis=0, prepend=centres[:1]).T)
            movers.append((centres, min(a, b) + radius - 0.5 * float(travel.max())))
        else:
            static |= grid.inside_ellipse(obs.position[:2], a + radius, b + radius,
                                          obs.orientation)
    for k in range(samples):
        out[k] = static
        for centres, r in movers:
            out[k] |= grid.inside_ellipse(centres[k], r, r, 0.0)
    return out


def earliest_arrival(occupied: np.ndarray, start: tuple[int, int], goal: np.ndarray,
                     cruise: float) -> float:
    """Earliest time [s] any cell of ``goal`` (bool grid) is reached from ``start``.

    ``occupied``: per sample (``STEP`` apart) the blocked cells; a blocked start is left at
    once (the robot is there). Waiting in a free cell is allowed.
    """
    n_t, nx, ny = occupied.shape
    horizon = (n_t - 1) * STEP
    best = np.full((nx, ny), math.inf)
    best[start] = 0.0
    heap = [(0.0, start)]
    moves = [(di, dj, CELL * math.hypot(di, dj) / cruise) for di, dj in MOVES]
    while heap:
        t, (i, j) = heapq.heappop(heap)
        if t > best[i, j]:
            continue
        if goal[i, j]:
            return t
        for di, dj, dt in moves:
            a, b = i + di, j + dj
            if not (0 <= a < nx and 0 <= b < ny):
                continue
            arrive = _free_arrival(occupied, (i, j), (a, b), t, dt, horizon)
            if arrive < best[a, b]:
                best[a, b] = arrive
                heapq.heappush(heap, (arrive, (a, b)))
    return math.inf


def _free_arrival(occupied, here, there, t, dt, horizon) -> float:
    """Earliest arrival at ``there`` leaving ``here`` at ``t`` or later, waiting in ``here``."""
    depart = t
    while depart + dt <= horizon:
        if not occupied[int(round((depart + dt) / STEP)), there[0], there[1]]:
            return depart + dt
        depart += STEP
        if occupied[int(round(depart / STEP)), here[0], here[1]]:
            return math.inf  # cannot wait here any longer
    return math.inf


def reach_bound(scenario: Scenario) -> ReachBound:
    """The least times of ``scenario`` (see the module docstring)."""
    start = np.asarray(scenario.robot.position[:2], dtype=float)
    goal = np.asarray(scenario.goal.position[:2], dtype=float)
    vertical = [o for o in scenario.obstacles if o.plane == "vertical"]
    times = np.arange(0.0, float(scenario.duration) + STEP / 2, STEP)
    paths = [scripted_centres(o, times) if moving(o) else None for o in vertical]
    points = [start, goal] + [np.asarray(o.position[:2], float) for o in vertical]
    points += [c for c in paths if c is not None]
    grid = _Grid(np.vstack(points))
    goal_cells = grid.near(goal, float(scenario.goal.tolerance))
    cruise = float(scenario.planner.speed or PlannerConfig().max_vx)
    blocked = occupancy(grid, vertical, times, TRUNK_RADIUS[scenario.robot.kind], paths)
    cell = grid.cell(start)
    nothing = np.broadcast_to(np.zeros((1,) + grid.x.shape, dtype=bool), blocked.shape)
    free = earliest_arrival(nothing, cell, goal_cells, cruise)
    with_obstacles = earliest_arrival(blocked, cell, goal_cells, cruise)
    return ReachBound(with_obstacles, free, with_obstacles - free)
