"""Obstacles the robot's body cannot pass, decided from geometry, and the stop expected there.

The robot walks the straight start-goal line (the planner never looks at obstacles); an
obstacle on that line is **impassable** when the body cannot get through it with the
clearance the safety filter is configured to keep, ``clearance = safety_margin`` (the
scenario's effective filter parameters) ``+ DEFAULT_MARGIN`` (the QP's own):

* a **bar** (``plane: horizontal``, static) whose underside is below the top of the trunk at
  the lowest base height the robot holds plus that clearance: ``lowest_base + trunk_top +
  clearance``, where ``lowest_base`` is the larger of the filter's ``min_height`` (defaults,
  config files and the scenario's overrides:
  :func:`safe_legged_c3bf.sim.scenario_clearance.filter_params`) and the gait controller's
  floor (``RobotSpec.min_base_height``), and ``trunk_top`` the trunk's top above the base
  origin (``RobotSpec.trunk_top``). It blocks when the straight path crosses its axis at
  least half a body width inside its ends.
* a **gap** between two static vertical obstacles, narrower than the body width
  (``RobotSpec.width``) plus the clearance on each side, that the straight path goes
  through (it crosses the segment between the two surfaces).

A blocker the bare body would pass (with less than the clearance) is marked ``by_margin``:
a filter that passed it would break its own margin, so the held stop is the expected outcome;
campaigns report these apart from the blockers of geometry alone.

What the robot must then do (:func:`held_stop`): stop before the first impassable obstacle,
untouched, and hold the stop to the end of the run without creeping: its progress along the
path over the last ``window`` s (ground truth, /odom of the simulator) stays below ``creep``.
Reaching the goal untouched (around the obstacle) is a success too. Units: m, s; odom frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from safe_legged_c3bf.sim.scenario import ObstacleConfig, Scenario

#: Default window (s) and bound (m) of the no-creep check.
CREEP_WINDOW = 5.0
CREEP_BOUND = 0.05
#: Boundary points per ellipse for the surface gap.
ELLIPSE_POINTS = 96


@dataclass(frozen=True)
class BodyEnvelope:
    """What the robot's body needs to pass (m).

    Attributes:
        robot: robot kind.
        width: body width across the path (legs included).
        trunk_top: trunk top above the base origin.
        lowest_base: lowest base height the robot holds under this scenario's filter.
        clearance: what the filter keeps from every obstacle: its ``safety_margin`` plus the
            QP's ``DEFAULT_MARGIN``.

    """

    robot: str
    width: float
    trunk_top: float
    lowest_base: float
    clearance: float = 0.0

    @property
    def lowest_top(self) -> float:
        """Trunk top (m above ground) at the lowest base height."""
        return self.lowest_base + self.trunk_top


@dataclass(frozen=True)
class Blocker:
    """An impassable obstacle (or pair) on the straight path.

    Attributes:
        ids: obstacle id(s): one bar, or the two obstacles of a gap.
        kind: 'bar' or 'gap'.
        station: distance (m) along the path from the start to the obstacle's near side.
        reason: why it is impassable, with the numbers.
        by_margin: the bare body would pass; the filter's clearance does not.

    """

    ids: tuple[str, ...]
    kind: str
    station: float
    reason: str
    by_margin: bool = False


def body_envelope(scenario: Scenario) -> BodyEnvelope:
    """The body envelope of ``scenario``'s robot under its effective filter parameters."""
    from safe_legged_c3bf.c3bf.filter import DEFAULT_MARGIN
    from safe_legged_c3bf.sim.robots import robot_spec
    from safe_legged_c3bf.sim.scenario_clearance import filter_params

    spec = robot_spec(scenario.robot.kind)
    params = filter_params(scenario)
    lowest = max(float(params.min_height), spec.min_base_height)
    clearance = float(params.safety_margin) + DEFAULT_MARGIN
    return BodyEnvelope(spec.kind, spec.width, spec.trunk_top, lowest, clearance)


def bar_impassable(underside: float, envelope: BodyEnvelope, clearance: bool = True) -> bool:
    """True when a bar's ``underside`` (m) is below the lowest trunk top plus the clearance.

    ``clearance=False``: below the bare trunk top.
    """
    return underside < envelope.lowest_top + (envelope.clearance if clearance else 0.0)


def gap_impassable(gap: float, envelope: BodyEnvelope, clearance: bool = True) -> bool:
    """True when a surface-to-surface ``gap`` (m) is narrower than the body and clearances.

    The clearance counts on each side; ``clearance=False``: narrower than the bare body.
    """
    return gap < envelope.width + (2.0 * envelope.clearance if clearance else 0.0)


def ellipse_outline(obs: ObstacleConfig, n: int = ELLIPSE_POINTS) -> np.ndarray:
    """``(n, 2)`` points on a vertical obstacle's ellipse at its start position (odom, m)."""
    a, b = obs.semi_axes
    u = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    c, s = math.cos(obs.orientation), math.sin(obs.orientation)
    x, y = a * np.cos(u), b * np.sin(u)
    return np.column_stack([obs.position[0] + c * x - s * y, obs.position[1] + s * x + c * y])


def surface_gap(a: ObstacleConfig, b: ObstacleConfig) -> tuple[float, np.ndarray, np.ndarray]:
    """(gap in m, nearest point on ``a``, nearest point on ``b``) of two vertical obstacles."""
    pa, pb = ellipse_outline(a), ellipse_outline(b)
    d = np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2)
    i, j = np.unravel_index(int(np.argmin(d)), d.shape)
    return float(d[i, j]), pa[i], pb[j]


def _path(scenario: Scenario) -> tuple[np.ndarray, np.ndarray, float]:
    """(start, unit tangent, length) of the straight start-goal line."""
    start = np.asarray(scenario.robot.position, dtype=float)
    goal = np.asarray(scenario.goal.position, dtype=float)
    length = float(np.linalg.norm(goal - start))
    tangent = (goal - start) / length if length > 0 else np.array([1.0, 0.0])
    return start, tangent, length


def _bar_blocker(obs: ObstacleConfig, scenario: Scenario, env: BodyEnvelope) -> Blocker | None:
    start, tangent, length = _path(scenario)
    if abs(tangent[0]) < 1e-9:
        return None  # the path runs along the bar
    s = (obs.position[0] - start[0]) / tangent[0]
    y = start[1] + s * tangent[1]
    if not 0.0 < s < length or abs(y - obs.position[1]) > obs.extent / 2 - env.width / 2:
        return None
    a, b = obs.semi_axes
    c, sn = math.cos(obs.orientation), math.sin(obs.orientation)
    half_x = math.hypot(a * c, b * sn)  # the ellipse's half-width along x
    half_z = math.hypot(a * sn, b * c)
    underside = obs.position[2] - half_z
    if not bar_impassable(underside, env):
        return None
    station = s - half_x / abs(tangent[0])
    by_margin = not bar_impassable(underside, env, clearance=False)
    return Blocker((obs.id,), "bar", station, (
        f"bar {obs.id!r}: underside {underside:.3f} m below the trunk top {env.lowest_top:.3f} m "
        f"at the lowest base height {env.lowest_base:.3f} m (+ trunk top {env.trunk_top:.3f})"
        f" + the filter's clearance {env.clearance:.3f} m"
        + (" (the bare trunk would pass)" if by_margin else "")), by_margin)


def _gap_blocker(a: ObstacleConfig, b: ObstacleConfig, scenario: Scenario,
                 env: BodyEnvelope) -> Blocker | None:
    start, tangent, length = _path(scenario)
    gap, pa, pb = surface_gap(a, b)
    if not gap_impassable(gap, env):
        return None
    normal = np.array([-tangent[1], tangent[0]])
    da, db = float((pa - start) @ normal), float((pb - start) @ normal)
    if da * db > 0.0:
        return None  # both nearest points on one side: the path does not go between them
    u = da / (da - db) if da != db else 0.5
    cross = pa + u * (pb - pa)
    s = float((cross - start) @ tangent)
    if not 0.0 < s < length:
        return None
    near = min(float(np.min((ellipse_outline(o) - start) @ tangent)) for o in (a, b))
    by_margin = not gap_impassable(gap, env, clearance=False)
    return Blocker((a.id, b.id), "gap", max(near, 0.0), (
        f"gap between {a.id!r} and {b.id!r}: {gap:.3f} m, narrower than the body "
        f"({env.width:.3f} m) + the filter's clearance {env.clearance:.3f} m on each side"
        + (" (the bare body would pass)" if by_margin else "")), by_margin)


def impassable_obstacles(scenario: Scenario) -> list[Blocker]:
    """The impassable bars and gaps on the straight path, nearest first (static ones only)."""
    env = body_envelope(scenario)
    static = [o for o in scenario.obstacles if o.motion.type == "static"]
    out = [blk for o in static if o.plane == "horizontal"
           for blk in [_bar_blocker(o, scenario, env)] if blk]
    vertical = [o for o in static if o.plane == "vertical"]
    for i, a in enumerate(vertical):
        for b in vertical[i + 1:]:
            blk = _gap_blocker(a, b, scenario, env)
            if blk:
                out.append(blk)
    return sorted(out, key=lambda blk: blk.station)


@dataclass(frozen=True)
class HeldStop:
    """Result of :func:`held_stop` (m).

    Attributes:
        held: stopped before the first blocker and no creep in the window.
        final_station: final base position along the path.
        creep: largest forward progress in the last ``window`` s.
        margin: blocker station minus the final station (> 0: before it).

    """

    held: bool
    final_station: float
    creep: float
    margin: float


def held_stop(scenario: Scenario, odom: np.ndarray, blockers: list[Blocker],
              window: float = CREEP_WINDOW, creep: float = CREEP_BOUND) -> HeldStop | None:
    """Whether the robot stopped before the first blocker and held it (ground-truth ``odom``).

    ``odom``: rows (t, x, y, ...) of the base in odom over the run. None without blockers or
    when the run is shorter than ``window``. Collisions are judged by the caller.
    """
    if not blockers or len(odom) < 2 or odom[-1, 0] - odom[0, 0] < window:
        return None
    start, tangent, _ = _path(scenario)
    s = (odom[:, 1:3] - start) @ tangent
    last = odom[:, 0] >= odom[-1, 0] - window
    progress = float(np.max(s[last]) - s[last][0])
    margin = blockers[0].station - float(s[-1])
    return HeldStop(margin > 0.0 and progress <= creep, float(s[-1]), progress, margin)
