"""Checks of the random scenarios' promises, on any :class:`Scenario` (m, s; odom frame).

The "nominal robot" walks the straight start-goal line at the profile's ``nominal_speed``
after ``start_delay`` (:func:`nominal_robot_position`); obstacles follow their scripted
motion (:class:`~safe_legged_c3bf.sim.obstacles.MotionScript`), sampled every ``dt`` s.

* :func:`obstacle_gaps`: every obstacle is in the nominal robot's way (gap < 0);
* :func:`meeting_walks`: how far each mover walks before and after meeting it;
* :func:`start_goal_clearance`: no obstacle comes near the start or the goal;
* :func:`passages`: no mover at rest closes a passage with another obstacle.
"""

from __future__ import annotations

import math

import numpy as np

from safe_legged_c3bf.evaluation.random_profile import RandomProfile, profile_for
from safe_legged_c3bf.sim.scenario import ObstacleConfig, Scenario


def nominal_robot_position(scenario: Scenario, t: float, profile: RandomProfile) -> np.ndarray:
    """Where a robot walking the straight start-goal line at the nominal speed is at ``t``."""
    start = np.asarray(scenario.robot.position, dtype=float)
    goal = np.asarray(scenario.goal.position, dtype=float)
    length = float(np.linalg.norm(goal - start))
    if length <= 0.0:
        return start
    s = min(max(t - profile.start_delay, 0.0) * profile.nominal_speed, length)
    return start + (goal - start) * (s / length)


def _sample_times(scenario: Scenario, dt: float) -> np.ndarray:
    """Sample times (s) over the whole run, ``dt`` apart."""
    return np.arange(0.0, scenario.duration + 1e-9, dt)


def _nominal_path(scenario: Scenario, times: np.ndarray, p: RandomProfile) -> np.ndarray:
    """``(len(times), 2)`` positions of the nominal straight-line robot."""
    return np.array([nominal_robot_position(scenario, t, p) for t in times])


def scripted_centres(obs: ObstacleConfig, times: np.ndarray) -> np.ndarray:
    """``(len(times), 2)`` x-y centres of ``obs`` along its scripted motion."""
    from safe_legged_c3bf.sim.obstacles import MotionScript

    script = MotionScript(obs.position, obs.motion)
    return np.array([script.state(float(t))[0][:2] for t in times])


def obstacle_gaps(
    scenario: Scenario, profile: RandomProfile | None = None, dt: float = 0.05
) -> dict[str, float]:
    """Per obstacle: how far the nominal straight-line robot stays from colliding with it (m).

    Vertical obstacles: min over time of (distance to the ellipse - half_width), so walls and
    benches count by their real shape; negative means the unfiltered robot runs into it.
    Horizontal bars: (underside height - trunk top) where the bar spans the path, +inf when
    it does not. Uses
    :class:`~safe_legged_c3bf.sim.obstacles.MotionScript` for the scripted motion.
    """
    p = profile or profile_for(scenario.robot.kind)
    times = _sample_times(scenario, dt)
    robot_xy = _nominal_path(scenario, times, p)
    gaps: dict[str, float] = {}
    for obs in scenario.obstacles:
        if obs.plane == "horizontal":
            lo, hi = robot_xy[:, 0].min(), robot_xy[:, 0].max()
            half = obs.extent / 2.0
            spans = (lo <= obs.position[0] <= hi
                     and np.any(np.abs(robot_xy[:, 1] - obs.position[1]) <= half))
            underside = obs.position[2] - max(obs.semi_axes)
            gaps[obs.id] = underside - p.trunk_top if spans else math.inf
            continue
        centres = scripted_centres(obs, times)
        dist = ellipse_distance(robot_xy - centres, obs.semi_axes, obs.orientation)
        gaps[obs.id] = float(dist.min() - p.half_width)
    return gaps


def ellipse_distance(
    points: np.ndarray, semi_axes, orientation: float, n: int = 180
) -> np.ndarray:
    """Distance (m) of ``(k, 2)`` points, relative to an ellipse's centre, to the ellipse.

    Negative inside (minus the distance to the boundary). The boundary is sampled at ``n``
    points, so the distance is exact to about ``a (1 - cos(pi / n))`` (0.15 mm per m of a).
    """
    a, b = semi_axes
    c, s = math.cos(orientation), math.sin(orientation)
    local = np.asarray(points, dtype=float) @ np.array([[c, -s], [s, c]])
    u = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    outline = np.column_stack([a * np.cos(u), b * np.sin(u)])
    d = np.linalg.norm(local[:, None, :] - outline[None, :, :], axis=2).min(axis=1)
    inside = (local[:, 0] / a) ** 2 + (local[:, 1] / b) ** 2 <= 1.0
    return np.where(inside, -d, d)


def meeting_walks(
    scenario: Scenario, profile: RandomProfile | None = None, dt: float = 0.05
) -> dict[str, tuple[float, float]]:
    """Per mover: how far (m) it walks before and after its closest approach to the robot.

    The robot is the nominal one walking the straight start-goal line
    (:func:`nominal_robot_position`). A mover that stops soon after meeting it stops where
    a filtered robot, which waited for it to pass, stands; one that starts soon before
    meeting it stands beside the path and walks into the robot as it arrives.
    """
    p = profile or profile_for(scenario.robot.kind)
    times = _sample_times(scenario, dt)
    robot_xy = _nominal_path(scenario, times, p)
    walks: dict[str, tuple[float, float]] = {}
    for obs in scenario.obstacles:
        if obs.plane == "horizontal" or not moving(obs):
            continue
        centres = scripted_centres(obs, times)
        k = int(np.argmin(np.linalg.norm(centres - robot_xy, axis=1)))
        steps = np.linalg.norm(np.diff(centres, axis=0), axis=1)
        walks[obs.id] = (float(steps[:k].sum()), float(steps[k:].sum()))
    return walks


def start_goal_clearance(scenario: Scenario, dt: float = 0.05) -> tuple[float, float]:
    """Least distances (m) from any obstacle's surface to the start and to the goal.

    Over the whole run, with the obstacle's circumscribed circle (inf without obstacles;
    bars are skipped).
    """
    start = np.asarray(scenario.robot.position, dtype=float)
    goal = np.asarray(scenario.goal.position, dtype=float)
    times = _sample_times(scenario, dt)
    to_start, to_goal = math.inf, math.inf
    for obs in scenario.obstacles:
        if obs.plane == "horizontal":
            continue
        centres = scripted_centres(obs, times)
        a = max(obs.semi_axes)
        to_start = min(to_start, float(np.linalg.norm(centres - start, axis=1).min() - a))
        to_goal = min(to_goal, float(np.linalg.norm(centres - goal, axis=1).min() - a))
    return to_start, to_goal


def moving(obs: ObstacleConfig) -> bool:
    """True when the obstacle's script moves it."""
    return obs.motion.type != "static"


def passages(scenario: Scenario) -> float:
    """Least surface gap (m) between a mover at rest and any other vertical obstacle at rest.

    inf when there is no such pair (circumscribed circles).
    """
    rest: list[tuple[bool, float, list[np.ndarray]]] = []
    for obs in scenario.obstacles:
        if obs.plane != "vertical":
            continue
        points = [np.asarray(obs.position[:2], dtype=float)]
        if moving(obs):
            points.append(np.asarray(obs.motion.waypoints[-1][:2], dtype=float))
        rest.append((moving(obs), max(obs.semi_axes), points))
    gap = math.inf
    for i, (mi, ai, pi) in enumerate(rest):
        for mj, aj, pj in rest[i + 1:]:
            if mi or mj:
                gap = min(gap, min(float(np.linalg.norm(p - q)) - ai - aj
                                   for p in pi for q in pj))
    return gap
