"""Drawing the obstacles of a random scenario, one conflict station at a time.

All positions are x-y in odom (m), angles in rad, speeds in m/s, times in s of sim time; the
robot walks from ``start`` along the unit ``tangent`` (``normal`` points to its left).
Obstacles come back as scenario mappings (the ``obstacles[i]`` entries of
doc/scenario_format.md), rounded to mm. :func:`conflict_stations` places the conflict stations;
:func:`static_obstacle`, :func:`moving_obstacle` and :func:`bar_obstacle` draw what stands
at one, :func:`side_obstacle` a pillar, bench or wall beside the path; :func:`leaves_passage`
checks whether a mover at rest closes a passage (no longer a rule of the generator). The
generator that combines them is
:func:`safe_legged_c3bf.evaluation.random_scenario.generate_scenario`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from safe_legged_c3bf.evaluation.random_profile import MOVING_KINDS, SHAPES, RandomProfile

# ------------------------------------------------------------------------------ geometry


def round_mm(x: float) -> float:
    """Round to mm (the YAML stays readable; clearances are far larger)."""
    return round(float(x), 3)


def xy_mm(p: np.ndarray) -> list[float]:
    """``[x, y]`` of a point (m), rounded to mm."""
    return [round_mm(p[0]), round_mm(p[1])]


# ------------------------------------------------------------------------------ obstacles


def conflict_stations(
    rng: np.random.Generator, n: int, lo: float, hi: float, spacing: float
) -> list:
    """``n`` sorted points in [lo, hi], at least ``spacing`` apart (fewer if they do not fit).

    Distances (m) along the start-goal line, from the start.
    """
    if hi < lo:
        return []
    n = max(0, min(n, int((hi - lo) // spacing) + 1))
    free = (hi - lo) - (n - 1) * spacing
    u = np.sort(rng.uniform(0.0, free, n))
    return [lo + float(u[i]) + i * spacing for i in range(n)]


def static_obstacle(
    rng, p: RandomProfile, index: int, point: np.ndarray, normal: np.ndarray,
    start: np.ndarray, goal: np.ndarray,
) -> dict[str, Any] | None:
    """A pillar at the conflict point ``point``, offset along ``normal`` into the path.

    Shrunk to keep ``start_clearance`` / ``goal_clearance`` m from the start and the goal;
    None when even a 0.1 m one would not fit.
    """
    a, b, shape = static_shape(rng, p)
    offset = rng.uniform(-1.0, 1.0) * p.in_way_fraction * (b + p.half_width)
    centre = point + offset * normal
    # Keep the surface clear of the start and the goal: shrink the ellipse if needed.
    room = min(float(np.linalg.norm(centre - start)) - p.start_clearance,
               float(np.linalg.norm(centre - goal)) - p.goal_clearance)
    if room < a:
        if room < 0.1:
            return None
        b, a = b * room / a, room
    return {
        "id": f"{shape}_{index}",
        "plane": "vertical",
        "position": xy_mm(centre),
        "semi_axes": [round_mm(a), round_mm(b)],
        "orientation": round_mm(rng.uniform(0.0, math.pi)),
        "extent": round_mm(rng.uniform(*p.height)),
        "color": [0.55, 0.55, 0.6, 1.0],
        "motion": {"type": "static"},
    }


def static_shape(rng, p: RandomProfile) -> tuple[float, float, str]:
    """Semi-axes (a, b) in m and the name of a static shape: pillar, bench or wall."""
    shape = SHAPES[int(rng.choice(len(SHAPES), p=np.asarray(p.shape_weights) / sum(
        p.shape_weights)))]
    if shape == "wall":
        return rng.uniform(*p.wall_length), rng.uniform(*p.wall_thickness), shape
    if shape == "bench":
        return rng.uniform(*p.bench_length), rng.uniform(*p.bench_depth), shape
    a = rng.uniform(*p.obstacle_radius)
    return a, a * rng.uniform(*p.aspect), shape


def side_obstacle(
    rng, p: RandomProfile, index: int, s: float, point: np.ndarray, tangent: np.ndarray,
    normal: np.ndarray, start: np.ndarray, goal: np.ndarray,
) -> dict[str, Any] | None:
    """A static pillar, bench or wall beside the path at ``s``: its long axis roughly along it.

    Its surface is ``side_gap`` m from the straight line: the body may fit past (the
    single-point filter's circle often does not). None when it would not keep clear of the
    start and the goal.
    """
    a, b, shape = static_shape(rng, p)
    psi = rng.uniform(-0.3, 0.3)  # long axis within ~17 deg of the path
    across = abs(a * math.sin(psi)) + abs(b * math.cos(psi))  # half-extent across the path
    side = 1.0 if rng.random() < 0.5 else -1.0
    centre = point + side * (across + rng.uniform(*p.side_gap)) * normal
    if min(float(np.linalg.norm(centre - start)) - p.start_clearance,
           float(np.linalg.norm(centre - goal)) - p.goal_clearance) < a:
        return None
    return {
        "id": f"side_{shape}_{index}", "plane": "vertical", "position": xy_mm(centre),
        "semi_axes": [round_mm(a), round_mm(b)],
        "orientation": round_mm(math.atan2(tangent[1], tangent[0]) + psi),
        "extent": round_mm(rng.uniform(*p.height)), "color": [0.5, 0.5, 0.55, 1.0],
        "motion": {"type": "static"},
    }


def moving_obstacle(
    rng, p: RandomProfile, index: int, station: float, point: np.ndarray,
    tangent: np.ndarray, normal: np.ndarray, start: np.ndarray, goal: np.ndarray,
    delay: float = 0.0,
) -> dict[str, Any] | None:
    """A mover through the conflict point ``point`` at the robot's nominal arrival time.

    ``delay`` (s) shifts the meeting time (crowd walkers that pass before or after the
    robot). The walk may pass through the start and the goal and stop anywhere, next to the
    path or on it; only where it stands at t = 0 keeps ``start_clearance`` from the start
    (the filter refuses a robot starting inside an obstacle), and where it stands at t = 0
    and where it stops keep ``goal_clearance`` from the goal (a goal inside it could not be
    reached).
    """
    weights = np.asarray(p.kind_weights, dtype=float)
    kind = MOVING_KINDS[int(rng.choice(len(MOVING_KINDS), p=weights / weights.sum()))]
    side = 1.0 if rng.random() < 0.5 else -1.0
    if kind == "crossing":
        psi = side * (math.pi / 2 + rng.uniform(-0.25, 0.25))
    elif kind == "head_on":
        psi = math.pi + rng.uniform(-0.15, 0.15)
    else:
        psi = side * rng.uniform(2.0, 2.6)
    direction = math.cos(psi) * tangent + math.sin(psi) * normal
    a = rng.uniform(*p.obstacle_radius) * 0.85  # people-sized rather than pillar-sized
    b = a * rng.uniform(0.75, 1.0)
    speed = rng.uniform(*p.mover_speed)
    offset = rng.uniform(-1.0, 1.0) * 0.5 * p.in_way_fraction * (b + p.half_width)
    meet = point + offset * normal
    t_meet = max(p.start_delay + station / p.nominal_speed + delay, 0.0)
    pre = min(rng.uniform(*p.pre_travel), speed * t_meet)
    post = rng.uniform(*p.post_travel)
    p1 = meet + post * direction
    if float(np.linalg.norm(p1 - goal)) < a + p.goal_clearance:
        return None  # it would stop on the goal
    for _ in range(60):  # shorten the approach until it stands clear at t = 0
        p0 = meet - pre * direction
        if (float(np.linalg.norm(p0 - start)) >= a + p.start_clearance
                and float(np.linalg.norm(p0 - goal)) >= a + p.goal_clearance):
            break
        pre *= 0.9
    else:
        return None
    if float(np.linalg.norm(p1 - p0)) < 1e-3:
        return None
    start_time = max(t_meet - pre / speed, 0.0)
    return {
        "id": f"{kind}_{index}",
        "plane": "vertical",
        "position": xy_mm(p0),
        "semi_axes": [round_mm(a), round_mm(b)],
        "orientation": round_mm(math.atan2(direction[1], direction[0])),
        "extent": round_mm(rng.uniform(*p.height)),
        "color": [0.85, 0.35, 0.2, 1.0],
        "motion": {
            "type": "waypoints", "waypoints": [xy_mm(p1)], "speed": round_mm(speed), "mode": "stop",
            "start_time": round_mm(start_time),
        },
    }


def _rest_positions(obstacle: dict[str, Any]) -> list[np.ndarray]:
    """Where a vertical obstacle stands still: its start and, for a mover, its stop."""
    points = [np.asarray(obstacle["position"][:2], dtype=float)]
    motion = obstacle.get("motion") or {}
    if motion.get("type") == "waypoints":
        points.append(np.asarray(motion["waypoints"][-1], dtype=float))
    return points


def leaves_passage(new: dict[str, Any], others: list[dict[str, Any]], passage: float) -> bool:
    """True unless a mover at rest (``new`` or one of ``others``) closes a gap with another.

    Checked for every pair involving a mover: each rest position keeps ``passage`` m between
    the circumscribed circles. Bars and static-static pairs are not checked.
    """
    if new.get("plane") != "vertical":
        return True
    new_moves = (new.get("motion") or {}).get("type") == "waypoints"
    a_new = max(new["semi_axes"])
    for other in others:
        if other.get("plane") != "vertical":
            continue
        if not new_moves and (other.get("motion") or {}).get("type") != "waypoints":
            continue
        reach = a_new + max(other["semi_axes"]) + passage
        for p in _rest_positions(new):
            for q in _rest_positions(other):
                if float(np.linalg.norm(p - q)) < reach:
                    return False
    return True


def bar_obstacle(rng, p: RandomProfile, index: int, point: np.ndarray) -> dict[str, Any]:
    """A bar across the path at ``point``: axis along odom y, height of its axis as z (m)."""
    radius = rng.uniform(*p.bar_radius)
    underside = rng.uniform(*p.bar_underside)
    return {
        "id": f"bar_{index}",
        "plane": "horizontal",
        "position": [round_mm(point[0]), round_mm(point[1]), round_mm(underside + radius)],
        "semi_axes": [round_mm(radius), round_mm(radius)],
        "extent": 4.0,
        "color": [0.2, 0.6, 0.25, 1.0],
    }

