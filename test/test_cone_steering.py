"""Cone steering (the whole-body filter's reference shaping in front of the QP)."""

import math

import numpy as np
import pytest

from safe_legged_c3bf.safety.cone_steering import ConeSteering, blocked_headings


def test_blocked_headings_are_the_collision_cone_within_the_horizon():
    p, w, r = np.array([[2.0, 0.0]]), np.zeros((1, 2)), np.array([0.5])
    psi = np.radians([0.0, 10.0, 14.0, 15.0, 30.0, 180.0])
    blocked = blocked_headings(psi, 0.5, p, w, r, 20.0)
    assert blocked.tolist() == [True, True, True, False, False, False]  # asin(0.25) = 14.5 deg
    assert not blocked_headings(np.zeros(1), 0.5, p, w, r, 2.0)[0]  # 1 m in 2 s: out of reach


def test_a_walker_crossing_blocks_the_heading_that_meets_it():
    p, w, r = np.array([[2.0, -2.0]]), np.array([[0.0, 0.5]]), np.array([0.4])
    assert blocked_headings(np.zeros(1), 0.5, p, w, r, 20.0)[0]  # both reach (2, 0) at 4 s
    assert not blocked_headings(np.array([math.pi]), 0.5, p, w, r, 20.0)[0]


def test_the_reference_is_kept_where_free_and_turned_where_blocked():
    s = ConeSteering(20.0, 0.2, 0.5, 1.5)
    free = s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[2.0, 3.0]], [[0, 0]], [0.3], 1.0)
    assert (free.vx, free.yaw_rate, free.side) == (0.4, 0.0, 0)
    ahead = s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[2.0, -0.05]], [[0, 0]], [0.3], 1.0)
    assert ahead.side == 1 and ahead.yaw_rate > 0.0  # the nearer side: left
    assert ahead.vx == 0.0  # heading blocked: turn in place first
    # Turned 0.5 rad left, the planner turns back (reference heading 0.5 - 1.0 * 0.5 = 0):
    turned = s.steer(0.1, (0, 0), 0.5, 0.4, -1.0, [[2.0, -0.05]], [[0, 0]], [0.3], 1.0)
    assert turned.vx > 0.0 and turned.side == 1  # forward along the free heading, left


def test_the_side_is_kept_while_the_detours_are_alike():
    s = ConeSteering(20.0, 0.2, 0.5, 1.5, side_memory=3.0)
    first = s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[2.0, 0.02]], [[0, 0]], [0.3], 1.0)
    again = s.steer(1.0, (0, 0), 0.0, 0.4, 0.0, [[2.0, -0.02]], [[0, 0]], [0.3], 1.0)
    assert first.side == again.side


def test_no_free_heading_keeps_the_reference_for_the_qp_to_brake():
    s = ConeSteering(20.0, 0.2, 0.5, 1.5)
    ring = [[math.cos(a), math.sin(a)] for a in np.linspace(0, 2 * math.pi, 24, endpoint=False)]
    out = s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, ring, np.zeros((24, 2)), [0.3] * 24, 1.0)
    assert not out.free and (out.vx, out.yaw_rate) == (0.4, 0.0)


def test_a_free_heading_is_kept_off_the_cone_edge_and_not_turned_into_it():
    """Walking past a pillar on its left, a reference turning right towards the goal is
    clamped inside the free headings (EDGE_STEPS off the edge), not let into the cone."""
    s = ConeSteering(20.0, 0.2, 0.5, 1.5)
    pillar = ([[2.0, -0.3]], [[0.0, 0.0]], [0.3])
    out = s.steer(0.0, (0, 0), 0.6, 0.4, -2.0, *pillar, 1.0, speed=0.4)
    assert out.vx == 0.4 and out.side == 1  # kept walking, turned less than asked
    assert -2.0 < out.yaw_rate
    edge = ~blocked_headings(np.radians(np.arange(0, 90)), 0.4, np.array([[2.0, -0.3]]),
                             np.zeros((1, 2)), np.array([0.5]), 20.0)
    first_free = math.radians(int(np.argmax(edge)))
    target = 0.6 + out.yaw_rate / 1.5  # the heading the steering aims at
    assert target >= first_free + math.radians(5.0) - 1e-9


def test_a_clamped_reference_walks_at_the_planners_cruise_speed():
    """The planner slowed to 0.15 m/s for the heading error the steering holds: the robot
    walks the free heading at the 0.4 m/s it asked for 10 s ago, never faster."""
    pillar = ([[2.0, -0.3]], [[0.0, 0.0]], [0.3])
    plain = ConeSteering(20.0, 0.2, 0.5, 1.5)
    cruise = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0)
    for s in (plain, cruise):
        s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[9.0, 9.0]], [[0, 0]], [0.3], 1.0)  # free: 0.4
    slow = plain.steer(10.0, (0, 0), 0.6, 0.15, -2.0, *pillar, 1.0, speed=0.4)
    fast = cruise.steer(10.0, (0, 0), 0.6, 0.15, -2.0, *pillar, 1.0, speed=0.4)
    assert slow.side == fast.side == 1 and slow.yaw_rate == fast.yaw_rate
    assert slow.vx == 0.15 and fast.vx == 0.4
    # Unsteered, a slow reference stays slow; one that stops stops; the window forgets.
    free = cruise.steer(11.0, (0, 0), 0.0, 0.15, 0.0, [[9.0, 9.0]], [[0, 0]], [0.3], 1.0)
    assert free.vx == 0.15 and free.side == 0
    stop = cruise.steer(12.0, (0, 0), 0.6, 0.0, -2.0, *pillar, 1.0, speed=0.4)
    assert stop.vx == 0.0
    late = cruise.steer(45.0, (0, 0), 0.6, 0.15, -2.0, *pillar, 1.0, speed=0.4)
    assert late.vx == 0.15  # 0.4 was asked more than 30 s ago


def test_turning_towards_a_free_heading_scales_the_cruise_speed_by_the_error():
    pillar = ([[2.0, -0.05]], [[0.0, 0.0]], [0.3])
    s = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0)
    s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[9.0, 9.0]], [[0, 0]], [0.3], 1.0)
    out = s.steer(1.0, (0, 0), 0.0, 0.2, 0.0, *pillar, 1.0, speed=0.4)
    assert out.side != 0
    error = abs(out.yaw_rate) / 1.5  # heading_gain * error, below the yaw-rate limit
    assert out.vx == pytest.approx(0.4 * math.cos(error), rel=1e-6)
