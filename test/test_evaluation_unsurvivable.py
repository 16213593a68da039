"""The unsurvivable check: hand-made survivable and unsurvivable movers."""

from __future__ import annotations

import numpy as np
import pytest

from safe_legged_c3bf.evaluation.unsurvivable import (
    EscapeLimits,
    escape_limits,
    reach_box,
    reveal_times,
    unsurvivable_threats,
)
from safe_legged_c3bf.sim.scenario import load_scenario, parse_scenario


def charge(robot="biped", speed=0.6, start=(0.9, 0.0), radius=0.3, extent=1.7, start_time=2.0):
    """A walker waiting ahead of the robot that starts walking straight through it."""
    data = {
        "name": "charge", "robot": {"kind": robot}, "goal": {"position": [3.0, 3.0]},
        "duration": 12.0,
        "obstacles": [{"id": "walker", "position": list(start), "semi_axes": [radius, radius],
                       "extent": extent,
                       "motion": {"type": "waypoints", "waypoints": [[-3.0, 0.0]],
                                  "speed": speed, "mode": "stop", "start_time": start_time}}],
    }
    return parse_scenario(data, name="charge")  # no clearance check: it starts near the robot


def standing(duration=12.0, x=0.0, y=0.0):
    """Ground truth of a robot standing at (x, y) facing +x: rows (t, x, y, z, yaw)."""
    t = np.arange(0.0, duration, 0.01)
    return np.column_stack([t, np.full_like(t, x), np.full_like(t, y), np.full_like(t, 0.8),
                            np.zeros_like(t)])


def test_escape_limits_take_the_most_permissive_of_filter_and_controller():
    biped = escape_limits(load_scenario("biped_crowd"))
    assert biped == EscapeLimits(0.2, 0.1, 0.08, 0.4)
    a1 = escape_limits(load_scenario("quadruped_crowd"))
    assert a1.forward == 1.0 and a1.reverse == 1.0 and a1.lateral == 0.5


def test_reach_box_bounds_straight_motion_and_grows():
    box = reach_box(EscapeLimits(0.2, 0.1, 0.0, 0.0), 2.0, dt=0.01)
    assert box[-1, 0] == pytest.approx(0.4, abs=0.01)  # no turning: straight ahead only
    assert box[-1, 1] == pytest.approx(0.2, abs=0.01)
    assert box[-1, 2] == pytest.approx(0.0)
    turning = reach_box(EscapeLimits(0.2, 0.1, 0.0, 0.4), 2.0, dt=0.01)
    assert turning[-1, 2] > 0.05 and np.all(np.diff(turning, axis=0) >= 0)


def test_reveal_times_are_start_and_stop():
    sc = charge()
    times = reveal_times(sc.obstacles[0], sc.duration)
    assert times[0] == 0.0
    assert times[1] == pytest.approx(2.0, abs=0.03)  # starts walking
    assert times[-1] == pytest.approx(2.0 + 3.9 / 0.6, abs=0.05)  # stops


def test_a_fast_walker_charging_a_standing_biped_is_unsurvivable():
    (threat,) = unsurvivable_threats(charge(), standing())
    assert threat.obstacle == "walker"
    assert threat.t0 == pytest.approx(2.0, abs=0.03)
    assert 2.5 < threat.t1 < 4.0
    assert "walker" in threat.describe()


def test_survivable_cases_are_not_flagged():
    assert unsurvivable_threats(charge(speed=0.15), standing()) == []  # slow: step aside
    assert unsurvivable_threats(charge(robot="quadruped"), standing()) == []  # A1 is faster
    assert unsurvivable_threats(charge(start=(0.9, 1.0)), standing()) == []  # walks past
    assert unsurvivable_threats(charge(extent=0.4), standing()) == []  # under the torso
    # Without a trajectory only t = 0 counts: the robot had 2 s to leave before it started.
    assert unsurvivable_threats(charge()) == []
    # A robot standing elsewhere when the walker starts is not threatened.
    assert unsurvivable_threats(charge(), standing(y=-1.5)) == []
    # Already touching when the walker starts: the robot got there itself, no new threat.
    assert unsurvivable_threats(charge(start=(0.2, 0.0)), standing()) == []


def test_moving_at_t0_without_trajectory():
    assert unsurvivable_threats(charge(start_time=0.0, start=(0.5, 0.0), speed=0.8))


def test_named_scenarios_are_survivable_from_their_start():
    for name in ("quadruped_crowd", "biped_crowd", "quadruped_moving", "biped_moving"):
        assert unsurvivable_threats(load_scenario(name)) == [], name
