"""Free headings between the steering's grid steps: a doorway narrower than 5 deg (#19)."""

import math

import numpy as np
import pytest

from safe_legged_c3bf.safety.cone_steering import ConeSteering, blocked_headings
from safe_legged_c3bf.safety.free_headings import (
    MIN_ROOM,
    TANGENT_MARGIN,
    aim_in_run,
    first_free_run,
    tangent_offsets,
)

ROBOT, PILLAR, HORIZON = 0.2, 0.3, 20.0


def doorway(room: float, centre_y: float = 0.2, x: float = 3.0):
    """Two pillars at ``x`` leaving ``room`` (m) for the robot's disc centre round ``centre_y``."""
    gap = PILLAR + ROBOT + 0.5 * room
    centres = np.array([[x, centre_y + gap], [x, centre_y - gap]])
    return centres, np.zeros((2, 2)), np.array([PILLAR, PILLAR])


def test_tangent_offsets_are_just_outside_each_circles_cone():
    left, right = tangent_offsets(0.0, np.array([[2.0, 0.0]]), np.array([0.5]), math.pi, 10.0)
    expected = math.asin(0.25) + TANGENT_MARGIN
    assert left == pytest.approx([expected]) and right == pytest.approx([expected])
    p, r = np.array([[2.0, 0.0]]), np.array([0.5])
    assert not blocked_headings(np.array([expected, -expected]), 0.4, p, np.zeros((1, 2)),
                                r, HORIZON).any()
    assert blocked_headings(np.array([expected - 2 * TANGENT_MARGIN]), 0.4, p,
                            np.zeros((1, 2)), r, HORIZON)[0]
    # Out of reach, inside, and beyond the largest turn: no candidate.
    none = tangent_offsets(0.0, np.array([[9.0, 0.0], [0.1, 0.0]]), np.array([0.5, 0.5]),
                           math.pi, 5.0)
    assert none[0].size == none[1].size == 0
    behind = tangent_offsets(0.0, np.array([[-2.0, 0.0]]), np.array([0.5]), math.pi / 2, 10.0)
    assert behind[0].size == behind[1].size == 0


def test_the_first_free_run_and_its_aim():
    offsets = np.radians([1.0, 2.0, 3.0, 5.0, 10.0, 15.0])
    free = np.array([False, True, True, False, True, True])
    first, last = first_free_run(free, offsets)
    assert (first, last) == (offsets[1], offsets[2])
    assert aim_in_run(first, last, math.radians(10.0)) == pytest.approx(math.radians(2.5))
    assert aim_in_run(0.0, 1.0, 0.1) == pytest.approx(0.1)  # wide: edge past the first
    assert first_free_run(np.zeros(3, dtype=bool), offsets[:3]) is None
    assert first_free_run(np.array([True, True]), offsets[:2]) == (offsets[0], offsets[1])


@pytest.mark.parametrize("room", [0.05, 0.087, 0.12])
def test_a_doorway_narrower_than_a_grid_step_is_found_and_aimed_at_its_middle(room):
    """quadruped_gap as the sensors leave it: the grid's headings round the doorway are all
    blocked, so without the tangents the steering turned to the far side of a pillar."""
    centres, w, radii = doorway(room)
    p, r = centres, radii + ROBOT
    grid = np.radians(np.arange(-100.0, 101.0, 5.0))
    free_grid = ~blocked_headings(grid, 0.4, p, w, r, HORIZON)
    assert not free_grid[(grid >= 0.0) & (grid <= math.radians(20.0))].any()
    s = ConeSteering(HORIZON, ROBOT, 0.5, 1.5)
    out = s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, centres, w, radii, 1.0, speed=0.4)
    assert out.free and out.side == 1
    target = out.yaw_rate / 1.5  # below the yaw-rate limit: the heading aimed at
    assert not blocked_headings(np.array([target]), 0.4, p, w, r, HORIZON)[0]
    middle = math.atan2(0.2, 3.0)
    assert target == pytest.approx(middle, abs=math.radians(0.3))


def test_a_window_with_less_than_the_least_room_is_not_aimed_at():
    """2.4 cm across, seen from 3 m: a heading the robot cannot hold; the steering turns past
    a pillar instead (the biped that walked into such a passage stood in it)."""
    centres, w, radii = doorway(0.6 * MIN_ROOM)
    p, r = centres, radii + ROBOT
    middle = math.atan2(0.2, 3.0)
    assert not blocked_headings(np.array([middle]), 0.4, p, w, r, HORIZON)[0]  # it exists
    s = ConeSteering(HORIZON, ROBOT, 0.5, 1.5)
    out = s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, centres, w, radii, 10.0, speed=0.4)
    assert out.free and abs(out.yaw_rate / 1.5 - middle) > math.radians(5.0)


def test_a_robot_inside_a_narrow_window_is_turned_to_its_middle_not_held_at_its_yaw():
    """Walking through the doorway off its middle, the planner turning back towards its goal
    straight ahead: the reference goes to the window's middle (before: the yaw was kept)."""
    centres, w, radii = doorway(0.087)
    middle = math.atan2(0.2, 3.0)
    yaw = middle - math.radians(0.5)
    s = ConeSteering(HORIZON, ROBOT, 0.5, 1.5)
    out = s.steer(0.0, (0, 0), yaw, 0.4, -0.2, centres, w, radii, 1.0, speed=0.4)
    assert out.free and out.side == 1 and out.vx == 0.4
    assert yaw + out.yaw_rate / 1.5 == pytest.approx(middle, abs=math.radians(0.2))


def test_random_doorways_give_a_free_heading_whenever_one_exists():
    rng = np.random.default_rng(7)
    s = ConeSteering(HORIZON, ROBOT, 0.5, 1.5)
    fine = np.radians(np.arange(-100.0, 100.0, 0.05))
    for k in range(60):
        room = rng.uniform(0.01, 0.3)
        centres, w, radii = doorway(room, rng.uniform(-0.6, 0.6), rng.uniform(1.0, 4.0))
        p, r = centres, radii + ROBOT
        out = s.steer(10.0 * k, (0, 0), 0.0, 0.4, 0.0, centres, w, radii, 1.0, speed=0.4)
        if not blocked_headings(np.zeros(1), 0.4, p, w, r, HORIZON)[0]:
            continue  # straight on is free: nothing to steer
        exists = not blocked_headings(fine, 0.4, p, w, r, HORIZON).all()
        assert out.free == exists
        target = out.yaw_rate / 1.5
        if abs(out.yaw_rate) < 1.0:  # not clipped at the yaw-rate limit
            assert not blocked_headings(np.array([target]), 0.4, p, w, r, HORIZON)[0]
