"""The least detour: hand-made pillars and walls with known shortest paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from safe_legged_c3bf.evaluation.detour_bound import (
    crosses_interior,
    detour_bound,
    shortest_path_length,
)
from safe_legged_c3bf.evaluation.unsurvivable import TRUNK_RADIUS
from safe_legged_c3bf.sim.scenario import parse_scenario

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # counter-clockwise


def scenario(obstacles, goal=(4.0, 0.0), speed=0.4):
    """An A1 at the origin facing +x, its goal at ``goal``, the planner at ``speed``."""
    data = {"name": "detour", "robot": {"kind": "quadruped"}, "goal": {"position": list(goal)},
            "planner": {"mode": "goal", "speed": speed}, "duration": 30.0,
            "obstacles": obstacles}
    return parse_scenario(data, name="detour")


def pillar(x, y, radius, **extra):
    """A vertical cylinder of ``radius`` at (x, y)."""
    return {"id": f"p{x}_{y}", "position": [x, y], "semi_axes": [radius, radius], **extra}


def around_disc(distance, radius):
    """Shortest path [m] between two points ``distance`` either side of a disc's centre."""
    tangent = math.sqrt(distance**2 - radius**2)
    arc = radius * (math.pi - 2.0 * math.acos(radius / distance))
    return 2.0 * tangent + arc


def test_a_segment_through_the_middle_crosses_and_one_along_an_edge_or_at_a_corner_does_not():
    p = np.array([[-1.0, 0.5], [0.0, 0.0], [-1.0, 1.0], [-1.0, -1.0], [2.0, 0.5]])
    q = np.array([[2.0, 0.5], [1.0, 0.0], [1.0, -1.0], [-0.5, -1.0], [1.5, 0.5]])
    assert crosses_interior(p, q, SQUARE).tolist() == [True, False, False, False, False]


def test_no_obstacle_leaves_the_straight_line():
    bound = detour_bound(scenario([]))
    assert bound.shortest == pytest.approx(4.0)
    assert bound.extra_time == pytest.approx(0.0)


def test_a_pillar_on_the_line_costs_the_way_round_its_grown_disc_and_no_more():
    radius = 0.3
    bound = detour_bound(scenario([pillar(2.0, 0.0, radius)]))
    grown = radius + TRUNK_RADIUS["quadruped"]
    # The inscribed polygon lies between the grown disc and the disc its sides touch.
    assert around_disc(2.0, grown * math.cos(math.pi / 32)) < bound.shortest
    assert bound.shortest < around_disc(2.0, grown)
    assert bound.extra_time == pytest.approx((bound.shortest - 4.0) / 0.4)


def test_a_pillar_beside_the_line_beyond_the_robot_costs_nothing():
    bound = detour_bound(scenario([pillar(2.0, 0.3 + TRUNK_RADIUS["quadruped"] + 0.01, 0.3)]))
    assert bound.extra_time == pytest.approx(0.0, abs=1e-9)


def test_movers_and_bars_are_left_out():
    walker = pillar(2.0, 0.0, 0.3, motion={"type": "waypoints", "waypoints": [[2.0, 3.0]],
                                           "speed": 0.3})
    bar = {"id": "bar", "plane": "horizontal", "position": [2.0, 0.0, 0.5],
           "semi_axes": [0.05, 0.05], "extent": 4.0}
    assert detour_bound(scenario([walker, bar])).extra_time == pytest.approx(0.0)


def test_a_closed_ring_has_no_way_out():
    ring = [np.array([[math.cos(a), math.sin(a)] for a in np.linspace(0, 2 * math.pi, 9)[:-1]])
            * 0.3 + 3.0 * np.array([math.cos(b), math.sin(b)])
            for b in np.linspace(0.0, 2 * math.pi, 40, endpoint=False)]
    assert math.isinf(shortest_path_length(np.zeros(2), np.array([5.0, 0.0]), ring))


def test_an_elongated_wall_across_the_line_is_walked_round_its_end():
    wall = {"id": "wall", "position": [2.0, 0.0], "semi_axes": [1.0, 0.1],
            "orientation": math.pi / 2}
    bound = detour_bound(scenario([wall]))
    end = 1.0 + TRUNK_RADIUS["quadruped"]  # the grown ellipse's end beside the line
    assert bound.shortest == pytest.approx(2.0 * math.hypot(2.0, end), rel=0.01)
