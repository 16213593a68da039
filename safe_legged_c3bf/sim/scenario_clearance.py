"""Load-time checks that a scenario's start and goal are not inside an obstacle.

"Inside" means inside the obstacle as the safety filter inflates it
(:func:`safe_legged_c3bf.safety.obstacle_input.to_c3bf_obstacles`), with the filter
parameters the bringup would give it: the defaults, ``config/safety_filter.yaml``, the robot's
``config/robots/<kind>.yaml`` and the scenario's ``filter:`` overrides, in that order. A robot
that starts there begins with a violated barrier; a goal there cannot be reached safely.

* **Vertical obstacle**: a circle around the centre of radius largest semi-axis +
  robot_width / 2 + safety_margin. The start is checked as the filter sees it at t = 0: the body
  point (``offset`` ahead of the base along the start heading, unicycle model) against the
  circle moved ``tie_break`` to the robot's right and grown by as much. The goal is checked as
  a point, without the heading-dependent tie-break.
* **Horizontal bar**: it counts where the robot's y is within its extent grown by
  robot_width / 2 + horizontal_y_margin. In the x-z plane it is a circle of radius largest
  semi-axis + robot_height / 2 + safety_margin around its axis; the point is inside when no body
  height in [min_height, max_height] (the range the filter lets the robot duck and rise in)
  clears that circle at the point's x (the body point's for the start).
* **Moving obstacles** are checked where they are at t = 0 (their ``position``), against the
  start and the goal; one that comes to rest for good (``waypoints``, ``mode: stop``) is also
  checked at its last waypoint against the goal. Where they pass in between is the filter's job.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from safe_legged_c3bf.safety.params import FilterParams
    from safe_legged_c3bf.sim.scenario import ObstacleConfig, Scenario


def _config_filter_values(kind: str) -> list[dict[str, Any]]:
    """Filter parameters of config/safety_filter.yaml and config/robots/<kind>.yaml."""
    from safe_legged_c3bf.run.config import config_path, load_yaml

    out = []
    try:
        node = load_yaml(config_path("safety_filter.yaml")).get("safety_filter") or {}
        out.append(dict(node.get("ros__parameters") or {}))
    except (FileNotFoundError, OSError, AttributeError):
        pass
    try:
        profile = load_yaml(config_path("robots", f"{kind}.yaml"))
        out.append(dict(profile.get("safety_filter") or {}))
    except (FileNotFoundError, OSError, AttributeError):
        pass
    return out


def filter_params(scenario: Scenario) -> FilterParams:
    """The filter parameters a bringup of ``scenario`` would use.

    Raises:
        ValueError: naming the parameter, when the scenario's overrides are invalid.

    """
    from safe_legged_c3bf.safety.params import FilterParams

    params = FilterParams()
    for values in _config_filter_values(scenario.robot.kind):
        try:
            params = params.updated(**values)
        except (TypeError, ValueError):
            continue  # a broken config file is reported by the node that reads it
    try:
        return params.updated(**scenario.overrides.get("filter", {}))
    except TypeError as err:
        raise ValueError(f"{err}") from None


def _bar(
    x: float, y: float, obs: ObstacleConfig, centre: tuple[float, float, float],
    p: FilterParams,
) -> str | None:
    """Why (x, y) is under bar ``obs`` lower than the robot can duck, or None."""
    half_span = 0.5 * obs.extent + 0.5 * p.robot_width + p.horizontal_y_margin
    if abs(y - centre[1]) > half_span:
        return None
    radius = max(obs.semi_axes) + 0.5 * p.robot_height + p.safety_margin
    dx = abs(x - centre[0])
    if dx >= radius:
        return None
    h = math.sqrt(radius * radius - dx * dx)
    low, high = centre[2] - h, centre[2] + h
    if not (low < p.min_height and high > p.max_height):
        return None
    return (
        f"under obstacle {obs.id!r}, a bar lower than the robot can duck: at x = {x:.3f} m, "
        f"{dx:.3f} m from the bar's axis (height {centre[2]:.3f} m), the bar inflated to radius "
        f"{radius:.3f} m (largest semi-axis {max(obs.semi_axes):.3f} + robot_height/2 "
        f"{0.5 * p.robot_height:.3f} + safety_margin {p.safety_margin:.3f}) covers heights "
        f"{max(low, 0.0):.3f} to {high:.3f} m, the whole range the filter allows "
        f"(min_height {p.min_height:.3f} to max_height {p.max_height:.3f} m)"
    )


def _rest_positions(obs: ObstacleConfig) -> list[tuple[str, tuple[float, float, float]]]:
    """Where the obstacle is checked against the goal: its start and, if it stops, its end."""
    out = [("at its start position", obs.position)]
    m = obs.motion
    if m.type == "waypoints" and m.mode == "stop" and m.waypoints:
        out.append(("where it stops (its last waypoint)", m.waypoints[-1]))
    return out


def clearance_problems(scenario: Scenario, p: FilterParams) -> list[str]:
    """Error lines for a start or goal inside an inflated obstacle (empty when clear)."""
    from safe_legged_c3bf.safety.params import TURNING_MODELS

    problems = []
    sx, sy = scenario.robot.position
    yaw = scenario.robot.yaw
    offset = p.offset if p.model in TURNING_MODELS else 0.0
    body = (sx + offset * math.cos(yaw), sy + offset * math.sin(yaw))
    shift = (p.tie_break * math.sin(yaw), -p.tie_break * math.cos(yaw))
    point = "its body point" if offset else "its base"
    gx, gy = scenario.goal.position
    for obs in scenario.obstacles:
        c = obs.position
        size = max(obs.semi_axes)
        grown = size + 0.5 * p.robot_width + p.safety_margin
        parts = (f"largest semi-axis {size:.3f} + robot_width/2 {0.5 * p.robot_width:.3f} + "
                 f"safety_margin {p.safety_margin:.3f}")
        if obs.plane == "vertical":
            centre = (c[0] + shift[0], c[1] + shift[1])
            dist = math.dist(body, centre)
            if dist < grown + p.tie_break:
                problems.append(
                    f"robot.position: the robot starts inside obstacle {obs.id!r} as the "
                    f"safety filter inflates it: {point} ({body[0]:.3f}, {body[1]:.3f}) is "
                    f"{dist:.3f} m from the obstacle's centre at its start position, less than "
                    f"the inflated radius {grown + p.tie_break:.3f} m ({parts} + tie_break "
                    f"{p.tie_break:.3f}, the centre moved as far to the robot's right)"
                )
        else:
            why = _bar(body[0], sy, obs, c, p)
            if why:
                problems.append(f"robot.position: the robot starts {why}")
        for when, at in _rest_positions(obs):
            if obs.plane == "vertical":
                dist = math.dist((gx, gy), at[:2])
                why = None if dist >= grown else (
                    f"inside obstacle {obs.id!r} as the safety filter inflates it: "
                    f"({gx:.3f}, {gy:.3f}) is {dist:.3f} m from the obstacle's centre {when}, "
                    f"less than the inflated radius {grown:.3f} m ({parts})"
                )
            else:
                why = _bar(gx, gy, obs, at, p)
                why = why and f"{why}; the bar {when}"
            if why:
                problems.append(f"goal.position: the goal is {why}")
                break
    return problems
