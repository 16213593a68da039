"""Movers the robot should overtake, and whether it did (issue #17), judged from ground truth.

A **leader** is a vertical mover that starts ahead of the robot on its straight start-goal
path (its centre within ``LEADER_LATERAL`` of the path line, between the start and the goal)
and whose scripted motion at its start goes the robot's way (within ``LEADER_ANGLE`` of the
path direction) slower than the planner's cruise speed. A robot that only keeps its distance
follows a leader to the end of the run; one that gets past it **overtakes** it: at some
sample the robot's progress along the path exceeds the leader's while the two are beside
each other (centres less than ``BESIDE`` apart across the path). Used by
:mod:`.expectations` (fields ``leaders`` and ``overtook``). Units: m, s, rad; odom frame.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from safe_legged_c3bf.sim.scenario import ObstacleConfig, Scenario

#: Largest distance (m) of a leader's start from the path line.
LEADER_LATERAL = 0.5
#: Largest angle (rad) between a leader's initial velocity and the path direction.
LEADER_ANGLE = math.radians(30.0)
#: Centres closer than this across the path (m) are beside each other.
BESIDE = 1.5
#: Cruise speed (m/s) when the scenario does not set the planner's.
DEFAULT_CRUISE = 0.4


def _path(scenario: Scenario) -> tuple[np.ndarray, np.ndarray, float]:
    """(start, unit direction, length) of the straight start-goal path."""
    start = np.asarray(scenario.robot.position[:2], dtype=float)
    delta = np.asarray(scenario.goal.position[:2], dtype=float) - start
    length = float(np.linalg.norm(delta))
    return start, delta / max(length, 1e-9), length


def leaders(scenario: Scenario) -> list[ObstacleConfig]:
    """The movers of the module docstring's definition, in scenario order."""
    from safe_legged_c3bf.sim.obstacles import MotionScript

    start, along, length = _path(scenario)
    cruise = scenario.planner.speed or DEFAULT_CRUISE
    out = []
    for obs in scenario.obstacles:
        if obs.plane != "vertical" or obs.motion.type == "static":
            continue
        rel = np.asarray(obs.position[:2], dtype=float) - start
        s, d = float(rel @ along), float(along[0] * rel[1] - along[1] * rel[0])
        if not (0.0 < s < length and abs(d) <= LEADER_LATERAL):
            continue
        script = MotionScript(obs.position, obs.motion)
        t0 = max(float(obs.motion.start_time or 0.0), 0.0) + 0.1
        velocity = np.asarray(script.state(t0)[1][:2], dtype=float)
        speed = float(np.linalg.norm(velocity))
        if 0.0 < speed < cruise and velocity @ along >= speed * math.cos(LEADER_ANGLE):
            out.append(obs)
    return out


def overtaken(scenario: Scenario, odom: np.ndarray, movers: list[ObstacleConfig]) -> list[str]:
    """Ids of the ``movers`` the robot got past (module docstring).

    ``odom``: ground-truth base rows (t, x, y, ...) in odom.
    """
    from safe_legged_c3bf.evaluation.random_checks import scripted_centres

    start, along, _ = _path(scenario)
    across = np.array([-along[1], along[0]])
    robot = odom[:, 1:3] - start
    passed = []
    for obs in movers:
        centres = scripted_centres(obs, odom[:, 0]) - start
        ahead = robot @ along > centres @ along
        beside = np.abs((robot - centres) @ across) < BESIDE
        if bool((ahead & beside).any()):
            passed.append(obs.id)
    return passed
