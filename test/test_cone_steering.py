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
    stop = cruise.steer(12.0, (0, 0), 0.6, 0.0, 0.0, *pillar, 1.0, speed=0.4)
    assert (stop.vx, stop.yaw_rate, stop.side) == (0.0, 0.0, 0)
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



def test_an_unbounded_horizon_steers_out_of_a_cone_at_any_distance_and_speed():
    """The barrier refuses a collision cone however far the obstacle is: so does the steering
    with its default horizon (inf). A pillar 6 m ahead, the planner slowed to 0.05 m/s to
    turn: within 20 s (1 m) the heading looked free and was kept for the QP to brake."""
    pillar = ([[6.0, 0.0]], [[0.0, 0.0]], [0.3])
    kept = ConeSteering(20.0, 0.2, 0.5, 1.5).steer(0.0, (0, 0), 0.0, 0.05, 0.0, *pillar, 1.0)
    assert (kept.vx, kept.yaw_rate, kept.side) == (0.05, 0.0, 0)
    turned = ConeSteering(math.inf, 0.2, 0.5, 1.5).steer(0.0, (0, 0), 0.0, 0.05, 0.0,
                                                         *pillar, 1.0)
    assert turned.side != 0 and turned.free
    p, r = np.array([[6.0, 0.0]]), np.array([0.5])
    psi = np.radians([0.0, 4.0, 5.0, 180.0])  # asin(0.5 / 6) = 4.8 deg
    assert blocked_headings(psi, 0.05, p, np.zeros((1, 2)), r, math.inf).tolist() == [
        True, True, False, False]
    # A walker crossing 6 m ahead: blocked where the two would meet, at any distance.
    w = np.array([[0.0, 0.3]])
    assert blocked_headings(np.zeros(1), 0.3, np.array([[6.0, -6.0]]), w, r, math.inf)[0]
    assert not blocked_headings(np.zeros(1), 0.3, np.array([[6.0, -6.0]]), w, r, 15.0)[0]


def _biped_past_a_pillar(horizon: float) -> tuple[float, float]:
    """``biped_default``'s start in the unit harness (biped profile, planner, first-order
    robot) with ``steer_horizon`` [s]: a pillar 2.5 m ahead, slightly right; the walker, not
    yet started, standing at (4.5, 1.6) beside the free side; the goal 6 m ahead. Returns the
    times [s] the robot is past the pillar (x > 3 m) and at its goal (inf: not in 60 s)."""
    from filter_harness import SimpleRobot

    from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
    from safe_legged_c3bf.planning.reference_planner import (
        PlannerConfig,
        ReferencePlanner,
        RobotPose,
    )
    from safe_legged_c3bf.run.parameters import robot_profile
    from safe_legged_c3bf.safety.obstacle_input import ObstacleInput
    from safe_legged_c3bf.safety.params import FilterParams
    from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle

    profile = robot_profile("biped")["safety_filter"]
    cycle = SafetyFilterCycle(FilterParams(**{**profile, "steer_horizon": horizon}))
    obstacles = [
        ObstacleInput("pillar", 0, np.array([2.5, -0.1, 0.9]), np.zeros(3),
                      np.array([0.25, 0.25]), 1.8, 0.0),
        ObstacleInput("walker", 0, np.array([4.5, 1.6, 0.85]), np.zeros(3),
                      np.array([0.22, 0.18]), 1.7, 0.0),
    ]
    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.15, z_nominal=0.82))
    goal = np.array([6.0, 0.0])
    planner.set_goal(*goal)
    robot = SimpleRobot(z=0.81, tau=0.3, holonomic=True)
    past, dt = math.inf, 0.02
    for k in range(int(60.0 / dt)):
        t = k * dt
        ref = planner.compute(RobotPose(robot.x, robot.y, robot.yaw, robot.z), t)
        out = cycle.step(t, VelocityCommand(ref.vx, ref.vy, 0.0, ref.yaw_rate), t,
                         robot.base_state(t), obstacles, t)
        for _ in range(5):
            robot.step(out.command, dt / 5)
        if robot.x > 3.0:
            past = min(past, t)
        if np.hypot(*(goal - (robot.x, robot.y))) < 0.3:
            return past, t
    return past, math.inf


def test_a_pillar_ahead_is_walked_round_not_crept_at():
    """With a 20 s horizon the pillar 2.5 m ahead looked free at the slow speeds the planner
    asks while it turns back, and the walker standing 4.8 m away did at any speed: the
    steering kept the heading, the QP braked it, the robot crept and turned to and fro
    (``biped_default``: 20 s before the pillar). The default (inf) walks round it."""
    from safe_legged_c3bf.safety.params import FilterParams

    assert FilterParams().steer_horizon == math.inf
    past, at_goal = _biped_past_a_pillar(math.inf)
    past_before, at_goal_before = _biped_past_a_pillar(20.0)
    print(f"\npast the pillar / at the goal: {past:.1f} / {at_goal:.1f} s "
          f"(20 s horizon: {past_before:.1f} / {at_goal_before:.1f} s)")
    assert at_goal < 45.0  # 6 m at 0.15 m/s: 40 s
    assert at_goal < at_goal_before - 8.0 and past < past_before - 4.0


def test_a_planner_stopped_to_turn_back_into_the_cone_walks_on_along_the_free_heading():
    """The planner stops walking once the heading error the steering holds grows (60 deg)
    and turns back in place: within ``side_memory`` of a steered reference, that turn is
    the steering's doing, and the robot walks on along the free heading at the planner's
    cruise speed instead of turning back into the cone (and to and fro), for
    ``side_memory`` s."""
    pillar = ([[2.0, -0.3]], [[0.0, 0.0]], [0.3])
    s = ConeSteering(math.inf, 0.2, 0.5, 1.5, side_memory=3.0, cruise_memory=30.0)
    walked = s.steer(0.0, (0, 0), 0.6, 0.4, -2.0, *pillar, 1.0, speed=0.4)
    assert walked.side == 1 and walked.vx == 0.4  # steered: clamped, walking
    back = s.steer(1.0, (0, 0), 0.6, 0.0, -2.0, *pillar, 1.0, speed=0.4)
    assert back.side == 1 and back.vx == 0.4 and back.yaw_rate > -2.0
    free = s.steer(2.0, (0, 0), 0.6, 0.0, -0.2, *pillar, 1.0, speed=0.4)  # a small turn
    assert (free.vx, free.yaw_rate, free.side) == (0.0, -0.2, 0)  # free: the planner's own
    still = s.steer(2.9, (0, 0), 0.6, 0.0, -2.0, *pillar, 1.0, speed=0.4)
    assert still.side == 1 and still.vx == 0.4
    # side_memory (3 s) after the last walking reference steered (t = 0), not renewed by the
    # turning back itself: the planner's turn (a robot held on would walk on for good).
    late = s.steer(3.5, (0, 0), 0.6, 0.0, -2.0, *pillar, 1.0, speed=0.4)
    assert (late.vx, late.yaw_rate, late.side) == (0.0, -2.0, 0)
