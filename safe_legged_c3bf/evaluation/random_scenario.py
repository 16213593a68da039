"""Seeded random scenarios with obstacles in the robot's way.

``generate_scenario("quadruped", seed=3)`` returns a scenario mapping (the YAML of
``doc/scenario_format.md``) that depends only on the robot kind and the seed:

* the robot starts at the origin with a random heading (yaw 0 when a bar is drawn: bars are
  extruded along odom y) and its goal lies ``goal_distance`` m straight ahead;
* ``obstacle_count`` obstacles get *conflict stations* along the straight start-goal line,
  at least ``spacing`` m apart, away from the start and the goal;
* a **static** obstacle (random ellipse, orientation, height) stands at its station with a
  lateral offset small enough that the straight path runs through it;
* a **moving** obstacle (``crossing`` ±90°, ``head_on`` 180° or ``oblique`` ±115-150° to the
  path, random speed) is timed to be at its station when a robot walking the straight line
  at ``nominal_speed`` (after ``start_delay``) gets there: it waits at its start
  (``start_time``), walks a straight segment through the conflict point and stops
  (``mode: stop``);
* a **bar** (quadruped only, probability ``bar_probability``) lies across the path with its
  underside below the standing robot's trunk top and above what a ducking robot needs; the
  scenario then carries the same ``filter:`` and ``planner:`` overrides as
  ``quadruped_horizontal``;
* biped scenarios carry the biped's command range and height as ``filter:`` overrides.

No obstacle ever comes near the start or the goal: the whole motion segment of every
obstacle keeps ``start_clearance`` / ``goal_clearance`` m between the obstacle's surface and
those points. No mover closes a passage: where it waits and where it stops it leaves at least
``passage`` m between its surface and every other obstacle's surface at rest (or its draw is
repeated). Without that rule a mover could stop beside a pillar the robot is passing and form
a dead end that only a global planner gets out of (seen with a straight-line planner: the
robot stood safe in the pocket until the time ran out). :func:`passages` re-checks that rule
and :func:`obstacle_gaps` the "in the way" property on any scenario: the straight-line robot
at its nominal speed meets every obstacle.

``python -m safe_legged_c3bf.evaluation.random_scenario --robot biped --seed 4`` prints one.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from safe_legged_c3bf.evaluation.random_checks import (
    meeting_walks,
    moving,
    nominal_robot_position,
    obstacle_gaps,
    passages,
    start_goal_clearance,
)
from safe_legged_c3bf.evaluation.random_profile import (
    BIPED_FILTER_OVERRIDES,
    MOVING_KINDS,
    PROFILES,
    ROBOTS,
    RandomProfile,
    profile_for,
)
from safe_legged_c3bf.sim.scenario import Scenario, parse_scenario

__all__ = [  # the profile and the checks are re-exported from their modules
    "BAR_FILTER_OVERRIDES", "BAR_PLANNER_OVERRIDES", "BIPED_FILTER_OVERRIDES", "MOVING_KINDS",
    "PROFILES", "ROBOTS", "RandomProfile", "generate_scenario", "main", "meeting_walks",
    "moving", "nominal_robot_position", "obstacle_gaps", "passages", "profile_for",
    "random_scenario", "scenario_yaml", "start_goal_clearance", "without_obstacles",
    "write_scenario",
]

#: Filter overrides of scenarios with a bar (as in config/scenarios/quadruped_horizontal.yaml).
BAR_FILTER_OVERRIDES = {"safety_margin": 0.03, "min_height": 0.18, "max_height": 0.285}
#: Planner overrides of scenarios with a bar: regain the height gently behind it.
BAR_PLANNER_OVERRIDES = {"k_z": 0.3}


# ------------------------------------------------------------------------------ geometry


def _segment_point_distance(p0: np.ndarray, p1: np.ndarray, q: np.ndarray) -> float:
    """Distance from point ``q`` to the segment p0-p1 (2D)."""
    d = p1 - p0
    denom = float(d @ d)
    u = 0.0 if denom <= 0.0 else float(np.clip((q - p0) @ d / denom, 0.0, 1.0))
    return float(np.linalg.norm(p0 + u * d - q))


def _r(x: float) -> float:
    """Round to mm (the YAML stays readable; clearances are far larger)."""
    return round(float(x), 3)


def _xy(p: np.ndarray) -> list[float]:
    return [_r(p[0]), _r(p[1])]


# ------------------------------------------------------------------------------ generator


def _stations(rng: np.random.Generator, n: int, lo: float, hi: float, spacing: float) -> list:
    """``n`` sorted points in [lo, hi], at least ``spacing`` apart (fewer if they do not fit)."""
    if hi < lo:
        return []
    n = max(0, min(n, int((hi - lo) // spacing) + 1))
    free = (hi - lo) - (n - 1) * spacing
    u = np.sort(rng.uniform(0.0, free, n))
    return [lo + float(u[i]) + i * spacing for i in range(n)]


def _static_obstacle(
    rng, p: RandomProfile, index: int, point: np.ndarray, normal: np.ndarray,
    start: np.ndarray, goal: np.ndarray,
) -> dict[str, Any] | None:
    a = rng.uniform(*p.obstacle_radius)
    b = a * rng.uniform(*p.aspect)
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
        "id": f"pillar_{index}",
        "plane": "vertical",
        "position": _xy(centre),
        "semi_axes": [_r(a), _r(b)],
        "orientation": _r(rng.uniform(0.0, math.pi)),
        "extent": _r(rng.uniform(*p.height)),
        "color": [0.55, 0.55, 0.6, 1.0],
        "motion": {"type": "static"},
    }


def _moving_obstacle(
    rng, p: RandomProfile, index: int, station: float, point: np.ndarray,
    tangent: np.ndarray, normal: np.ndarray, start: np.ndarray, goal: np.ndarray,
) -> dict[str, Any] | None:
    """A mover through the conflict point ``point`` at the robot's nominal arrival time."""
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
    t_meet = p.start_delay + station / p.nominal_speed
    pre = min(rng.uniform(*p.pre_travel), speed * t_meet)
    post = rng.uniform(*p.post_travel)
    # Shrink the approach (never below ``least_pre``) until the segment keeps clear of the
    # start and the goal, else draw again. The walk past the conflict point is never
    # shortened: a mover that stopped short of it stopped where the robot waits for it to
    # pass (seen: biped seeds 4, 10 and 14, walkers stopping 0.3-0.4 m beside the path, at
    # twice the biped's reverse speed); one that starts just before it stands beside the
    # path and walks into the robot as it arrives (biped seed 10 once its stop was fixed).
    least_pre = min(p.pre_travel[0], pre)
    for _ in range(40):
        p0, p1 = meet - pre * direction, meet + post * direction
        if (_segment_point_distance(p0, p1, start) >= a + p.start_clearance
                and _segment_point_distance(p0, p1, goal) >= a + p.goal_clearance):
            break
        if pre <= least_pre:
            return None
        pre = max(pre * 0.9, least_pre)
    else:
        return None
    start_time = max(t_meet - pre / speed, 0.0)
    return {
        "id": f"{kind}_{index}",
        "plane": "vertical",
        "position": _xy(p0),
        "semi_axes": [_r(a), _r(b)],
        "orientation": _r(math.atan2(direction[1], direction[0])),
        "extent": _r(rng.uniform(*p.height)),
        "color": [0.85, 0.35, 0.2, 1.0],
        "motion": {
            "type": "waypoints", "waypoints": [_xy(p1)], "speed": _r(speed), "mode": "stop",
            "start_time": _r(start_time),
        },
    }


#: Draws of a mover before its station gets a pillar instead.
MOVER_DRAWS = 10


def _rest_positions(obstacle: dict[str, Any]) -> list[np.ndarray]:
    """Where a vertical obstacle stands still: its start and, for a mover, its stop."""
    points = [np.asarray(obstacle["position"][:2], dtype=float)]
    motion = obstacle.get("motion") or {}
    if motion.get("type") == "waypoints":
        points.append(np.asarray(motion["waypoints"][-1], dtype=float))
    return points


def _leaves_passage(new: dict[str, Any], others: list[dict[str, Any]], passage: float) -> bool:
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


def _bar_obstacle(rng, p: RandomProfile, index: int, point: np.ndarray) -> dict[str, Any]:
    radius = rng.uniform(*p.bar_radius)
    underside = rng.uniform(*p.bar_underside)
    return {
        "id": f"bar_{index}",
        "plane": "horizontal",
        "position": [_r(point[0]), _r(point[1]), _r(underside + radius)],
        "semi_axes": [_r(radius), _r(radius)],
        "extent": 4.0,
        "color": [0.2, 0.6, 0.25, 1.0],
    }


def generate_scenario(
    robot: str = "quadruped",
    seed: int = 0,
    profile: RandomProfile | None = None,
    name: str | None = None,
) -> dict[str, Any]:
    """A random scenario mapping (YAML-ready) for ``robot``, fully determined by ``seed``.

    Args:
        robot: 'quadruped' or 'biped'.
        seed: non-negative integer; also the scenario's perception seed.
        profile: the ranges to draw from (default :data:`PROFILES` [robot]).
        name: scenario name (default ``random_<robot>_<seed:03d>``).

    """
    p = profile or profile_for(robot)
    if p.robot != robot:
        raise ValueError(f"profile is for {p.robot!r}, not {robot!r}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    rng = np.random.default_rng([int(seed), ROBOTS.index(robot)])
    length = rng.uniform(*p.goal_distance)
    use_bar = robot == "quadruped" and rng.random() < p.bar_probability
    yaw = rng.uniform(-math.pi, math.pi) if p.random_heading and not use_bar else 0.0
    tangent = np.array([math.cos(yaw), math.sin(yaw)])
    normal = np.array([-math.sin(yaw), math.cos(yaw)])
    start = np.zeros(2)
    goal = start + length * tangent
    count = int(rng.integers(p.obstacle_count[0], p.obstacle_count[1] + 1))
    stations = _stations(rng, count, p.first_station, length - p.last_station, p.spacing)
    bar_index = int(rng.integers(len(stations))) if use_bar and stations else -1
    obstacles: list[dict[str, Any]] = []
    for i, s in enumerate(stations):
        point = start + s * tangent
        if i == bar_index:
            obstacles.append(_bar_obstacle(rng, p, i, point))
            continue
        mover = None
        if rng.random() < p.moving_probability:
            for _ in range(MOVER_DRAWS):
                mover = _moving_obstacle(rng, p, i, s, point, tangent, normal, start, goal)
                if mover is None or _leaves_passage(mover, obstacles, p.passage):
                    break
                mover = None
        obstacle = mover or _static_obstacle(rng, p, i, point, normal, start, goal)
        if obstacle is not None and not _leaves_passage(obstacle, obstacles, p.passage):
            obstacle = None  # a pillar beside a resting mover: leave the station empty
        if obstacle is not None:
            obstacles.append(obstacle)
    kinds = sorted({o["id"].rsplit("_", 1)[0] for o in obstacles})
    data: dict[str, Any] = {
        "name": name or f"random_{robot}_{seed:03d}",
        "description": (
            f"Random {robot} scenario, seed {seed}: goal {length:.2f} m ahead at heading "
            f"{math.degrees(yaw):.0f} deg, {len(obstacles)} obstacle(s) in the way "
            f"({', '.join(kinds) or 'none'})."
        ),
        "robot": {"kind": robot, "position": _xy(start), "yaw": _r(yaw)},
        "goal": {"position": _xy(goal), "tolerance": 0.3},
        "duration": float(p.duration),
        "seed": int(seed),
        "perception": dict(p.perception),
        "planner": {"mode": "goal", "speed": float(p.cruise_speed)},
        "obstacles": obstacles,
    }
    overrides = dict(p.filter_overrides)
    if bar_index >= 0:
        overrides.update(BAR_FILTER_OVERRIDES)
        data["planner"].update(BAR_PLANNER_OVERRIDES)
    if overrides:
        data["filter"] = overrides
    return data


def random_scenario(robot: str = "quadruped", seed: int = 0, **kwargs: Any) -> Scenario:
    """The validated :class:`Scenario` of :func:`generate_scenario` (same arguments)."""
    data = generate_scenario(robot, seed, **kwargs)
    return parse_scenario(data, name=data["name"])


def scenario_yaml(data: dict[str, Any]) -> str:
    """YAML text of a scenario mapping, with a header comment."""
    header = (
        "# Generated by safe_legged_c3bf.evaluation.random_scenario (format: "
        "doc/scenario_format.md).\n"
    )
    return header + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)


def write_scenario(path: str | Path, data: dict[str, Any]) -> Path:
    """Validate ``data`` and write it as YAML to ``path``; return the path."""
    parse_scenario(data, name=str(data.get("name", Path(path).stem)))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(scenario_yaml(data), encoding="utf-8")
    return path


def without_obstacles(data: dict[str, Any], suffix: str = "_free") -> dict[str, Any]:
    """A copy of a scenario mapping with no obstacles (and no bar filter overrides needed).

    The reference run for the time-to-goal overhead: same robot, goal, planner and duration.
    """
    out = {k: v for k, v in data.items() if k != "obstacles"}
    out["obstacles"] = []
    out["name"] = f"{data.get('name', 'scenario')}{suffix}"
    out["description"] = f"{data.get('description', '')} Obstacles removed.".strip()
    return out


# ------------------------------------------------------------------------------ CLI


def main(argv: list[str] | None = None) -> int:
    """Print (or write) one random scenario."""
    parser = argparse.ArgumentParser(
        prog="python -m safe_legged_c3bf.evaluation.random_scenario",
        description="Print a seeded random scenario (YAML) with obstacles in the robot's way.",
    )
    parser.add_argument("--robot", choices=ROBOTS, default="quadruped")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("-o", "--output", type=Path, help="write to this file instead")
    opts = parser.parse_args(argv)
    data = generate_scenario(opts.robot, opts.seed)
    if opts.output:
        print(write_scenario(opts.output, data))
    else:
        sys.stdout.write(scenario_yaml(data))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
