"""Footstep planning limits, swing trajectories and support-polygon helpers."""

import math

import numpy as np
import pytest

from safe_legged_c3bf.gait.biped.footstep_planner import (
    Footstep,
    FootstepPlanner,
    clip_to_polygon,
    convex_hull,
)
from safe_legged_c3bf.gait.biped.params import BipedParams, GaitParams, StepLimits
from safe_legged_c3bf.gait.biped.swing_trajectory import SwingTrajectory
from safe_legged_c3bf.interfaces.rotations import wrap_angle


@pytest.fixture()
def planner():
    params = BipedParams()
    return FootstepPlanner(params.gait, params.steps)


def test_planned_steps_respect_limits_for_any_command(planner):
    rng = np.random.default_rng(0)
    lim = planner.limits
    for _ in range(300):
        support = Footstep(rng.choice(["l", "r"]), *rng.uniform(-1, 1, 2), rng.uniform(-3, 3))
        # commands far beyond the controller's own limits
        command = rng.uniform([-1.0, -0.5, -2.0], [1.0, 0.5, 2.0])
        prev = support
        for step in planner.plan(support, command, 6):
            assert step.side != prev.side
            assert planner.is_feasible(prev, step)
            dx, dy, dyaw = planner.relative(prev, step)
            sigma = 1.0 if step.side == "l" else -1.0
            assert -lim.max_backward - 1e-9 <= dx <= lim.max_forward + 1e-9
            assert lim.min_width - 1e-9 <= sigma * dy <= lim.max_width + 1e-9
            assert -lim.max_inward_yaw - 1e-9 <= sigma * dyaw <= lim.max_yaw + 1e-9
            prev = step


def test_zero_command_steps_in_place(planner):
    support = Footstep("r", 0.3, -0.1, 0.4)
    steps = planner.plan(support, np.zeros(3), 4)
    assert [s.side for s in steps] == ["l", "r", "l", "r"]
    first = steps[0]
    assert planner.is_aligned(support, first)
    assert math.hypot(first.x - support.x, first.y - support.y) == pytest.approx(0.2)
    assert steps[1].x == pytest.approx(support.x) and steps[1].y == pytest.approx(support.y)


def test_steady_command_gives_the_commanded_speed(planner):
    period = planner.gait.step_period
    for command in ([0.15, 0.0, 0.0], [0.0, 0.05, 0.0], [0.1, 0.0, 0.3], [-0.08, 0.0, 0.0]):
        command = np.array(command)
        support = Footstep("r", 0.0, -0.1, 0.0)
        steps = planner.plan(support, command, 9)
        same_side = steps[8]  # four full cycles after steps[0]
        first = steps[0]
        dyaw = wrap_angle(same_side.yaw - first.yaw)
        assert dyaw == pytest.approx(command[2] * 8 * period, abs=1e-9)
        if command[2] == 0.0:
            displacement = np.array([same_side.x - first.x, same_side.y - first.y])
            np.testing.assert_allclose(displacement, command[:2] * 8 * period, atol=1e-9)


def test_replanning_follows_a_new_command(planner):
    support = Footstep("l", 0.0, 0.1, 0.0)
    slow = planner.next_step(support, np.array([0.05, 0.0, 0.0]))
    fast = planner.next_step(support, np.array([0.15, 0.0, 0.0]))
    left = planner.next_step(support, np.array([0.0, 0.0, 0.3]))
    assert fast.x > slow.x > support.x
    assert left.yaw > 0.0


def test_clamp_is_a_projection(planner):
    support = Footstep("l", 0.0, 0.1, 0.0)
    wild = Footstep("r", 0.5, 0.3, 1.0)  # far ahead, crossing over, turned
    once = planner.clamp(support, wild)
    twice = planner.clamp(support, once)
    assert planner.is_feasible(support, once)
    assert (once.x, once.y, once.yaw) == pytest.approx((twice.x, twice.y, twice.yaw))


def test_first_swing_side_leads_the_motion():
    assert FootstepPlanner.first_swing_side(np.array([0.0, 0.05, 0.0])) == "l"
    assert FootstepPlanner.first_swing_side(np.array([0.0, -0.05, 0.0])) == "r"
    assert FootstepPlanner.first_swing_side(np.array([0.0, 0.0, -0.3])) == "r"


def test_polygon_helpers():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], dtype=float)
    hull = convex_hull(square)
    assert len(hull) == 4
    np.testing.assert_allclose(clip_to_polygon(np.array([0.3, 0.4]), hull), [0.3, 0.4])
    np.testing.assert_allclose(clip_to_polygon(np.array([2.0, 0.5]), hull), [1.0, 0.5])
    np.testing.assert_allclose(clip_to_polygon(np.array([-1.0, -1.0]), hull), [0.0, 0.0])


def test_swing_trajectory_lifts_and_lands():
    start = np.array([0.0, 0.1, 0.0, 0.0])
    target = np.array([0.12, 0.12, 0.0, 0.2])
    swing = SwingTrajectory(start, 1.0, 0.4, 0.05, 0.1, 0.85)
    times = np.arange(1.0, 1.4001, 0.005)
    poses = np.array([swing.sample(t, target)[0] for t in times])
    np.testing.assert_allclose(poses[0], start, atol=1e-12)
    np.testing.assert_allclose(poses[-1], target, atol=1e-9)
    assert poses[:, 2].max() == pytest.approx(0.05, abs=1e-3)
    assert np.all(poses[:, 2] >= -1e-12)
    # no horizontal motion before the lift fraction, none after landing
    assert np.allclose(poses[times <= 1.04][:, :2], start[:2])
    _, rate = swing.sample(1.4, target)
    np.testing.assert_allclose(rate, 0.0, atol=1e-9)


def test_swing_trajectory_absorbs_a_new_target_smoothly():
    start = np.array([0.0, 0.1, 0.0, 0.0])
    swing = SwingTrajectory(start, 0.0, 0.4, 0.05)
    target = np.array([0.1, 0.1, 0.0, 0.0])
    poses = []
    for t in np.arange(0.0, 0.4001, 0.005):
        if t > 0.2:
            target = np.array([0.16, 0.14, 0.0, 0.0])
        poses.append(swing.sample(t, target)[0])
    poses = np.array(poses)
    steps = np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1)
    assert steps.max() < 0.01  # no jump when the target moves
    np.testing.assert_allclose(poses[-1][:2], [0.16, 0.14], atol=1e-9)


def test_invalid_swing_parameters_raise():
    with pytest.raises(ValueError):
        SwingTrajectory(np.zeros(4), 0.0, 0.0, 0.05)


def test_step_limits_validation():
    with pytest.raises(ValueError):
        BipedParams(steps=StepLimits(min_width=0.3, max_width=0.2))
    with pytest.raises(ValueError):
        BipedParams(gait=GaitParams(step_width=0.4))
