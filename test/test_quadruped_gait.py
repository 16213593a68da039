"""Trot schedule, swing trajectories, footholds and the quadruped parameters."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from safe_legged_c3bf.gait.quadruped.gait_schedule import GaitMode, TrotSchedule
from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams
from safe_legged_c3bf.gait.quadruped.swing import min_jerk, raibert_foothold, swing_point

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# ---------------------------------------------------------------- gait schedule
def run_schedule(schedule: TrotSchedule, t0: float, t1: float, motion: bool, dt: float = 0.002):
    t = t0
    while t < t1 - 1e-12:
        t += dt
        schedule.update(t, motion)
    return t


def test_schedule_starts_standing_and_trots_on_motion():
    s = TrotSchedule(0.3, 0.5, 0.3)
    s.update(0.0, False)
    run_schedule(s, 0.0, 1.0, False)
    assert s.mode is GaitMode.STAND
    assert s.contacts().all()
    s.update(1.002, True)
    assert s.mode is GaitMode.TROT
    # the FL + RR pair lifts off first, FR + RL stay on the ground
    np.testing.assert_array_equal(s.contacts(), [True, False, False, True])
    contacts, progress, to_touchdown = s.snapshot()
    np.testing.assert_array_equal(contacts, s.contacts())
    np.testing.assert_allclose(progress, s.swing_progress())
    np.testing.assert_allclose(to_touchdown, s.time_to_touchdown())


def test_trot_alternates_diagonal_pairs():
    s = TrotSchedule(0.3, 0.5, 0.3)
    s.update(0.0, True)
    seen = set()
    t = 0.0
    for _ in range(300):
        t += 0.002
        s.update(t, True)
        c = tuple(bool(v) for v in s.contacts())
        seen.add(c)
        assert c[0] == c[3] and c[1] == c[2]  # diagonal pairs move together
        assert c[0] != c[1]  # exactly one pair on the ground (duty 0.5)
    assert seen == {(True, False, False, True), (False, True, True, False)}


def test_swing_progress_and_touchdown_times():
    s = TrotSchedule(0.4, 0.6, 0.3)
    s.update(0.0, True)
    s.update(0.1, True)  # phase 0.25
    phases = s.leg_phases()
    np.testing.assert_allclose(phases, [0.25, 0.75, 0.75, 0.25])
    progress = s.swing_progress()
    np.testing.assert_allclose(progress, [0.0, 0.375, 0.375, 0.0])
    np.testing.assert_allclose(s.time_to_touchdown(), [0.0, 0.1, 0.1, 0.0])
    assert s.stance_duration == pytest.approx(0.24)
    assert s.swing_duration == pytest.approx(0.16)


def test_plan_over_horizon():
    s = TrotSchedule(0.3, 0.5, 0.3)
    s.update(0.0, True)
    contacts, touchdowns = s.plan(10, 0.03)
    assert contacts.shape == (10, 4) and touchdowns.shape == (10, 4)
    # FR/RL in stance for 5 steps then swing; FL/RR swing then land after 5 steps
    np.testing.assert_array_equal(contacts[:, 0], [1] * 5 + [0] * 5)
    np.testing.assert_array_equal(contacts[:, 1], [0] * 5 + [1] * 5)
    np.testing.assert_array_equal(touchdowns[:, 1], [0] * 5 + [1] * 5)
    np.testing.assert_array_equal(touchdowns[:, 0], 0)
    s.reset()
    contacts, touchdowns = s.plan(10, 0.03)
    assert contacts.all() and not touchdowns.any()


def test_stops_with_all_feet_down_after_the_delay():
    s = TrotSchedule(0.3, 0.5, 0.3)
    s.update(0.0, True)
    t = run_schedule(s, 0.0, 0.37, True)  # mid-swing
    assert s.mode is GaitMode.TROT
    t_stop_request = t
    while s.mode is GaitMode.TROT:
        t += 0.002
        s.update(t, False)
        assert t < t_stop_request + 0.3 + 0.15 + 0.01  # delay + at most half a cycle
    assert t >= t_stop_request + 0.3 - 1e-9
    assert s.contacts().all()
    # and it stays standing
    run_schedule(s, t, t + 1.0, False)
    assert s.mode is GaitMode.STAND


def test_schedule_rejects_bad_arguments():
    with pytest.raises(ValueError):
        TrotSchedule(0.0, 0.5, 0.3)
    with pytest.raises(ValueError):
        TrotSchedule(0.3, 0.3, 0.3)


# ---------------------------------------------------------------- swing
def test_min_jerk_profile():
    assert min_jerk(0.0) == (0.0, 0.0)
    assert min_jerk(1.0) == (1.0, 0.0)
    assert min_jerk(0.5)[0] == pytest.approx(0.5)
    assert min_jerk(-1.0) == (0.0, 0.0) and min_jerk(2.0) == (1.0, 0.0)


def test_swing_point_endpoints_apex_and_velocity():
    start, end = (0.0, 0.0, 0.02), (0.1, -0.05, 0.03)
    duration, apex = 0.15, 0.08
    pos, vel = swing_point(start, end, 0.0, duration, apex)
    np.testing.assert_allclose(pos, start)
    np.testing.assert_allclose(vel, 0.0, atol=1e-12)
    pos, vel = swing_point(start, end, 1.0, duration, apex)
    np.testing.assert_allclose(pos, end)
    np.testing.assert_allclose(vel, 0.0, atol=1e-12)
    pos, _ = swing_point(start, end, 0.5, duration, apex)
    assert pos[2] == pytest.approx(0.03 + apex)
    # velocity is the derivative of position
    s, ds = 0.3, 1e-6
    p1, v = swing_point(start, end, s, duration, apex)
    p2, _ = swing_point(start, end, s + ds, duration, apex)
    np.testing.assert_allclose((np.array(p2) - p1) / (ds * duration), v, rtol=1e-4)


def test_raibert_foothold():
    hip, stance = (0.2, -0.1), 0.15
    # at rest: under the hip
    assert raibert_foothold(hip, (0, 0), (0, 0), (0, 0), 0.0, stance, 0.28, 0.17, 0.15) == hip
    # moving as commanded at 0.5 m/s: half a stance ahead
    x, y = raibert_foothold(hip, (0.5, 0), (0.5, 0), (0.5, 0), 0.0, stance, 0.28, 0.17, 0.15)
    assert x == pytest.approx(0.2 + 0.5 * stance / 2) and y == pytest.approx(-0.1)
    # slower than commanded: step shorter (feedback)
    x2, _ = raibert_foothold(hip, (0.5, 0), (0.3, 0), (0.5, 0), 0.0, stance, 0.28, 0.17, 0.15)
    assert x2 < x
    # bounded offset
    x3, y3 = raibert_foothold(hip, (5.0, 5.0), (0, 0), (0, 0), 0.0, stance, 0.28, 0.17, 0.15)
    assert math.hypot(x3 - hip[0], y3 - hip[1]) == pytest.approx(0.15)


# ---------------------------------------------------------------- parameters
def test_default_parameters_are_valid_and_match_the_yaml():
    defaults = QuadrupedParams()
    loaded = QuadrupedParams.from_yaml(os.path.join(ROOT, "config", "quadruped_controller.yaml"))
    assert loaded == defaults
    assert QuadrupedParams.from_dict(defaults.to_dict()) == defaults
    # the requirement: at least 8 cm of ducking below nominal
    assert defaults.body_height - defaults.min_body_height >= 0.08


@pytest.mark.parametrize(
    "name, value",
    [
        ("control_period", 0.0),
        ("control_period", float("nan")),
        ("mpc_horizon", 0),
        ("mpc_horizon", 2.5),
        ("mpc_period", 0.001),
        ("mass", -1.0),
        ("inertia", (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0)),
        ("inertia", (1.0, 0.2, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)),
        ("com_offset", (0.0, 0.0)),
        ("friction_coefficient", 0.0),
        ("min_normal_force", 500.0),
        ("weight_position", (1.0, -1.0, 1.0)),
        ("duty_factor", 0.3),
        ("min_body_height", 0.05),
        ("max_body_height", 0.5),
        ("body_height", 0.3),
        ("swing_kp", -1.0),
        ("osqp_max_iter", 0),
    ],
)
def test_bad_parameter_is_named(name, value):
    with pytest.raises(ValueError, match=name):
        QuadrupedParams(**{name: value})


def test_unknown_parameter_and_ros_file_layout():
    with pytest.raises(ValueError, match="no_such_param"):
        QuadrupedParams.from_dict({"no_such_param": 1.0})
    params = QuadrupedParams.from_dict({"/**": {"ros__parameters": {"gait_period": 0.4}}})
    assert params.gait_period == 0.4
    params = QuadrupedParams.from_dict({"mass": 12})  # ints accepted for floats
    assert params.mass == 12.0 and isinstance(params.mass, float)
