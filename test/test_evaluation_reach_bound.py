"""The clairvoyant least time: hand-made walkers the robot must wait for or may ignore."""

from __future__ import annotations

import math

import numpy as np
import pytest

from safe_legged_c3bf.evaluation.detour_bound import detour_bound
from safe_legged_c3bf.evaluation.reach_bound import earliest_arrival, reach_bound
from safe_legged_c3bf.sim.scenario import parse_scenario


def scenario(obstacles, goal=(3.0, 0.0), speed=0.4, duration=20.0):
    """An A1 at the origin, its goal (tolerance 0.3 m) at ``goal``, the planner at ``speed``."""
    data = {"name": "reach", "robot": {"kind": "quadruped"},
            "goal": {"position": list(goal), "tolerance": 0.3},
            "planner": {"mode": "goal", "speed": speed}, "duration": duration,
            "obstacles": obstacles}
    return parse_scenario(data, name="reach")


def crossing(speed):
    """A wide walker crossing the path at x = 1.5 m, from y = 1.6 m to y = -3 m."""
    return {"id": "walker", "position": [1.5, 1.6], "semi_axes": [0.5, 0.5],
            "motion": {"type": "waypoints", "waypoints": [[1.5, -3.0]], "speed": speed,
                       "mode": "stop"}}


def test_the_free_time_is_the_straight_walk_within_the_grid_error():
    bound = reach_bound(scenario([]))
    straight = (3.0 - 0.3) / 0.4
    assert straight <= bound.free <= straight * 1.03
    assert bound.extra_time == 0.0


def test_a_static_pillar_costs_about_its_least_detour():
    pillar = {"id": "pillar", "position": [1.5, 0.0], "semi_axes": [0.4, 0.4]}
    bound = reach_bound(scenario([pillar]))
    least = detour_bound(scenario([pillar])).extra_time
    assert least > 0.1
    assert bound.extra_time == pytest.approx(least, abs=0.03 * bound.free)


def test_a_walker_crossing_when_the_robot_arrives_costs_time_and_one_long_gone_does_not():
    # At 0.4 m/s both reach (1.5, 0) after 4 s; at 3 m/s the walker is there after 0.5 s.
    late = reach_bound(scenario([crossing(speed=0.4)]))
    assert late.extra_time > 0.5
    gone = reach_bound(scenario([crossing(speed=3.0)]))
    assert gone.extra_time <= 0.03 * gone.free


def test_waiting_is_allowed_and_a_closed_goal_is_never_reached():
    occupied = np.zeros((50, 20, 20), dtype=bool)
    occupied[:30, 10:13, :] = True  # a wall 3 cells thick across the grid for the first 3 s
    goal = np.zeros((20, 20), dtype=bool)
    goal[15, 5] = True
    t = earliest_arrival(occupied, (5, 5), goal, cruise=0.5)
    # 10 cells (0.5 m, 1 s) to walk; the wall opens at sample 30 (2.95 s, rounded), and the
    # 6 cells from its near side take 0.6 s, of which a knight's move (0.22 s) may jump the
    # first wall row unchecked (only arrivals are checked: the bound's side)
    assert 2.95 + 0.6 - 0.22 <= t <= 2.95 + 0.6 + 0.11
    occupied[:, 10:13, :] = True
    assert math.isinf(earliest_arrival(occupied, (5, 5), goal, cruise=0.5))
