"""The overtaking check (issue #17): which movers lead the robot, and whether it got past."""

from __future__ import annotations

import numpy as np
import pytest

from safe_legged_c3bf.evaluation.expectations import judge
from safe_legged_c3bf.evaluation.overtaking import leaders, overtaken
from safe_legged_c3bf.sim.scenario import load_scenario, parse_scenario


def mover(start=(2.0, 0.0), to=(14.0, 0.0), speed=0.12, kind="waypoints"):
    """A scenario: robot at the origin to a goal 9 m ahead, one obstacle (static or moving)."""
    motion = ({"type": "static"} if kind == "static" else
              {"type": "waypoints", "waypoints": [list(to)], "speed": speed, "mode": "stop"})
    data = {
        "name": "lead", "robot": {"kind": "quadruped"}, "goal": {"position": [9.0, 0.0]},
        "duration": 45.0, "planner": {"mode": "goal", "speed": 0.4},
        "obstacles": [{"id": "o", "position": list(start), "semi_axes": [0.3, 0.3],
                       "extent": 0.6, "motion": motion}],
    }
    return parse_scenario(data, name="lead")


def track(t, x, y):
    """Ground-truth rows (t, x, y, z, yaw)."""
    return np.column_stack([t, x, y, np.full_like(t, 0.28), np.zeros_like(t)])


@pytest.mark.parametrize(("scenario", "expected"), [
    (mover(), ["o"]),  # slower, ahead, same way
    (mover(speed=0.5), []),  # faster than the planner's 0.4 m/s: nothing to overtake
    (mover(to=(-10.0, 0.0)), []),  # head on
    (mover(to=(2.0, 10.0)), []),  # crossing
    (mover(kind="static"), []),  # static: a pillar, not a leader
    (mover(start=(2.0, 1.2)), []),  # beside the path, not on it
    (mover(start=(-1.0, 0.0)), []),  # behind the start
])
def test_leaders_are_slower_movers_ahead_going_the_robots_way(scenario, expected):
    assert [o.id for o in leaders(scenario)] == expected


def test_following_is_not_overtaking_and_passing_on_a_side_is():
    s = mover()
    t = np.arange(0.0, 45.0, 0.05)
    follow = track(t, np.minimum(0.12 * t + 1.2, 9.0), 0.0 * t)  # 0.8 m behind its centre
    assert overtaken(s, follow, leaders(s)) == []
    side = track(t, np.minimum(0.3 * t, 9.0), np.full_like(t, 0.7))
    assert overtaken(s, side, leaders(s)) == ["o"]
    far = track(t, np.minimum(0.3 * t, 9.0), np.full_like(t, 2.0))  # a detour: not beside
    assert overtaken(s, far, leaders(s)) == []


def test_the_named_overtaking_scenarios_have_a_leader_and_judge_reports_it():
    for name in ("quadruped_overtake_cart", "biped_overtake_walker", "quadruped_corridor_walker"):
        assert leaders(load_scenario(name)), name
    s = load_scenario("quadruped_overtake_cart")
    t = np.arange(0.0, 30.0, 0.05)
    rec = {"collision": False, "fallen": False, "sim_time": 30.0}
    out = judge(rec, s, track(t, np.minimum(0.35 * t, 9.0), 0.6 * np.sin(np.pi * t / 30.0)))
    assert out["leaders"] == "cart" and out["overtook"] is True
    out = judge(rec, load_scenario("quadruped_head_on"), track(t, 0.1 * t, 0.0 * t))
    assert out["leaders"] == "" and out["overtook"] is None
