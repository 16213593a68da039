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


def test_a_slowed_reference_is_judged_at_the_speed_the_steering_walks():
    """The planner slowed to 0.08 m/s (its heading error): 20 s at that speed reach 1.6 m, so
    a bench 2.9 m ahead looked out of reach and the reference passed unsteered, although the
    steered robot walks at its 0.4 m/s cruise and the barrier's cone (distance-free) refuses
    the heading. The heading is judged at the cruise speed: blocked, and steered."""
    bench = ([[2.9, 0.0]], [[0.0, 0.0]], [0.5])
    s = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0)
    s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[9.0, 9.0]], [[0, 0]], [0.3], 1.0)  # cruise 0.4
    assert not blocked_headings(np.zeros(1), 0.08, np.array([[2.9, 0.0]]), np.zeros((1, 2)),
                                np.array([0.7]), 20.0)[0]  # out of reach at 0.08 m/s
    out = s.steer(1.0, (0, 0), 0.0, 0.08, 0.0, *bench, 1.0, speed=0.1)
    assert out.side != 0 and out.yaw_rate != 0.0


def test_turning_towards_a_free_heading_scales_the_cruise_speed_by_the_error():
    pillar = ([[2.0, -0.05]], [[0.0, 0.0]], [0.3])
    s = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0)
    s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[9.0, 9.0]], [[0, 0]], [0.3], 1.0)
    out = s.steer(1.0, (0, 0), 0.0, 0.2, 0.0, *pillar, 1.0, speed=0.4)
    assert out.side != 0
    error = abs(out.yaw_rate) / 1.5  # heading_gain * error, below the yaw-rate limit
    assert out.vx == pytest.approx(0.4 * math.cos(error), rel=1e-6)


def test_first_free_offset_aims_a_narrow_run_at_its_middle():
    """Two steps off the blocked sector's edge where that heading is free; else the middle."""
    from safe_legged_c3bf.safety.stall_detour import first_free_offset

    offsets = np.radians(np.arange(5.0, 101.0, 5.0))
    free = np.zeros(offsets.size, dtype=bool)
    free[1] = True  # one free heading (10 deg) between two cones
    free[6:] = True
    assert math.degrees(first_free_offset(free, offsets, 2)) == pytest.approx(10.0)
    free[2] = True  # two: the first of them
    assert math.degrees(first_free_offset(free, offsets, 2)) == pytest.approx(10.0)
    free[3] = True  # three: two steps in, as before
    assert math.degrees(first_free_offset(free, offsets, 2)) == pytest.approx(20.0)
    end = np.zeros(offsets.size, dtype=bool)
    end[-1] = True  # a run at the scan's end
    assert math.degrees(first_free_offset(end, offsets, 2)) == pytest.approx(100.0)
    assert first_free_offset(np.zeros(offsets.size, dtype=bool), offsets, 2) is None
    # min_run 3 (the biped's): runs of one or two headings are passed over for the next,
    # except at the scan's end, where a run's true width is unknown.
    free = np.zeros(offsets.size, dtype=bool)
    free[1:3] = True
    free[6:] = True
    assert math.degrees(first_free_offset(free, offsets, 2, min_run=3)) == pytest.approx(45.0)
    assert math.degrees(first_free_offset(end, offsets, 2, min_run=3)) == pytest.approx(100.0)
    free[6:] = False
    assert first_free_offset(free, offsets, 2, min_run=3) is None


def test_a_turn_in_place_is_always_aimed_at_a_free_heading():
    """From rest with the heading blocked, the steering turns towards a heading it found free.

    Before, a free run narrower than ``EDGE_STEPS + 1`` steps was aimed ``EDGE_STEPS`` past its
    start, into the next cone: in random A1 seed 22 (oracle) that aim was the robot's own yaw,
    so the turn asked was 0 and the A1 stood 15 s before a bar (the closed loop below).
    """
    rng = np.random.default_rng(3)
    checked = 0
    for k in range(300):
        n = int(rng.integers(3, 9))
        ang = rng.uniform(-1.8, 1.8, n)
        dist = rng.uniform(0.8, 4.0, n)
        centres = np.column_stack([dist * np.cos(ang), dist * np.sin(ang)])
        radii = rng.uniform(0.1, 0.5, n)
        s = ConeSteering(20.0, 0.2, 0.5, 1.5)
        out = s.steer(10.0 * k, (0, 0), 0.0, 0.4, 0.0, centres, np.zeros((n, 2)), radii, 10.0,
                      speed=0.0)
        if out.side == 0 or out.detour:
            continue
        checked += 1
        target = out.yaw_rate / 1.5  # the heading turned to (yaw 0, no yaw-rate clipping)
        assert not blocked_headings(np.array([target]), 0.4, centres, np.zeros((n, 2)),
                                    radii + 0.2, 20.0)[0], k
    assert checked > 100


def test_the_a1_of_random_seed_22_turns_out_of_its_standstill():
    """Random A1 seed 22 (oracle) at 11 s, in the unit harness (A1 profile, first-order robot):
    at rest, its yaw blocked, the planner's heading blocked, one free heading 10 deg right of
    the planner's between two cones. The steering aimed two steps past it, at the robot's own
    yaw: it stood (6 mm in 5 s; in the run, 15 s). Now it turns to the free heading and walks
    (0.34 m in those 5 s)."""
    from safe_legged_c3bf.safety.obstacle_input import ObstacleInput

    obstacles = [  # the run's, the two walkers where they had stopped
        ObstacleInput(name, plane, np.array(c), np.zeros(3), np.array(ab), extent, th)
        for name, plane, c, ab, extent, th in [
            ("bar_0", 1, (2.39, 0.0, 0.375), (0.057, 0.057), 4.0, 0.0),
            ("head_on_1", 0, (3.3, 0.08, 0.58), (0.222, 0.185), 1.17, 3.007),
            ("pillar_2", 0, (4.839, 0.003, 0.6), (0.212, 0.133), 1.21, 2.097),
            ("side_bench_3", 0, (4.784, 1.146, 0.83), (0.626, 0.209), 1.66, -0.053),
            ("crossing_4", 0, (4.04, -1.51, 0.65), (0.157, 0.155), 1.29, -1.65),
            ("side_bench_5", 0, (1.633, -1.405, 0.6), (0.781, 0.243), 1.22, -0.005)]]
    walked = _a1_closed_loop((-0.72, 0.27, math.radians(-32.4), 0.28), (6.05, 0.0),
                             obstacles, 5.0)
    assert walked > 0.1


def test_from_rest_a_turn_settles_before_the_robot_walks_straight_along_the_free_heading():
    """Turned in place to a free heading, still turning: the reference stops the turn first
    (the offset body points would sweep their velocity across the cone as the robot walks
    off), then walks straight along the heading; once walking, the usual clamp applies."""
    pillar = ([[2.0, -0.05]], [[0.0, 0.0]], [0.3])
    off = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0)  # the default: no settling
    s = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0, settle_yaw_rate=0.05)
    for steering in (off, s):
        steering.steer(0.0, (0, 0), 0.0, 0.4, 0.0, [[9.0, 9.0]], [[0, 0]], [0.3], 1.0)
    at_once = off.steer(1.0, (0, 0), 0.5, 0.4, -1.0, *pillar, 1.0, speed=0.0, yaw_rate=0.3)
    assert at_once.vx == 0.4 and at_once.yaw_rate < 0.0
    turning = s.steer(1.0, (0, 0), 0.5, 0.4, -1.0, *pillar, 1.0, speed=0.0, yaw_rate=0.3)
    assert (turning.vx, turning.yaw_rate) == (0.0, 0.0) and turning.side == 1
    settled = s.steer(1.5, (0, 0), 0.5, 0.4, -1.0, *pillar, 1.0, speed=0.0, yaw_rate=0.02)
    assert (settled.vx, settled.yaw_rate) == (0.4, 0.0) and settled.side == 1
    walking = s.steer(2.0, (0, 0), 0.5, 0.4, -1.0, *pillar, 1.0, speed=0.3, yaw_rate=0.0)
    assert walking.vx == 0.4 and walking.yaw_rate < 0.0  # turning back towards the edge


def test_the_a1_walks_off_from_rest_past_a_far_pillar_without_creeping():
    """Random A1 seed 5 without its movers, in the unit harness (A1 profile): a pillar 4.2 m
    ahead, 0.14 m off the line to the goal. The robot turned in place to a free heading and
    was then asked to walk and turn back at once; the body point behind the base, swinging
    sideways with the turn, capped the forward acceleration near 0.1 m/s^2, the QP turned on
    to relax it, and the A1 crept: 0.37 m in 4 s. With the A1 profile's
    ``steer_settle_yaw_rate`` the turn settles first: 0.88 m."""
    from safe_legged_c3bf.safety.obstacle_input import ObstacleInput

    pillar = [ObstacleInput("pillar_2", 0, np.array([4.185, 0.298, 0.803]), np.zeros(3),
                            np.array([0.266, 0.206]), 1.606, 1.021)]
    assert _a1_closed_loop((0.0, 0.0, 0.096, 0.32), (6.676, 0.645), pillar, 4.0) > 0.6


def _a1_closed_loop(pose, goal, obstacles, seconds) -> float:
    """Distance [m] the harness A1 walks from ``pose`` (x, y, yaw, z) towards ``goal`` in
    ``seconds`` of closed loop (A1 profile, goal planner, first-order robot, 50 Hz)."""
    from filter_harness import SimpleRobot, goal_closed_loop

    from safe_legged_c3bf.planning.reference_planner import PlannerConfig, ReferencePlanner
    from safe_legged_c3bf.run.parameters import robot_profile
    from safe_legged_c3bf.safety.params import FilterParams
    from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle

    cycle = SafetyFilterCycle(FilterParams(**robot_profile("quadruped")["safety_filter"]))
    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.4, z_nominal=0.28))
    planner.set_goal(*goal)
    robot = SimpleRobot(x=pose[0], y=pose[1], yaw=pose[2], z=pose[3], tau=0.1, holonomic=True)
    goal_closed_loop(cycle, planner, robot, obstacles, 0.0, seconds)
    return math.hypot(robot.x - pose[0], robot.y - pose[1])


@pytest.mark.xfail(strict=True, reason=(
    "#17: random biped seed 17 (oracle) in the unit harness. The steering turns the biped "
    "left round a bench while the QP has stepped it out of a head-on walker's cone to the "
    "right; with the walker closing faster than the biped backs away, forward on the left "
    "lies across the cone, and the biped backs at 2 cm/s until the walker stops. Keeping the "
    "steering to the QP's side of the cone fixed it here but not in the simulator (README, "
    "session 31)"))
def test_the_biped_of_random_seed_17_passes_a_head_on_walker():
    """A bench 1.4 m ahead, a walker 4.5 m ahead walking at the biped at 0.17 m/s (through
    the bench) and stopping 0.75 m from its start, a second one crossing: the goal, 3.4 m
    ahead, within 30 s (3.4 m at the planner's 0.2 m/s take 17 s)."""
    assert _biped_seed_17() < 0.3


def _biped_seed_17() -> float:
    """Distance [m] from the goal after 30 s of the harness biped in random biped seed 17."""
    from filter_harness import SimpleRobot, Walker, goal_closed_loop

    from safe_legged_c3bf.planning.reference_planner import PlannerConfig, ReferencePlanner
    from safe_legged_c3bf.run.parameters import robot_profile
    from safe_legged_c3bf.safety.params import FilterParams
    from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle

    profile = robot_profile("biped")
    params = FilterParams(**profile["safety_filter"]).updated(  # the scenario's filter section
        max_reverse_speed=0.1, max_yaw_accel=0.8, min_height=0.7, max_height=0.9)
    cycle = SafetyFilterCycle(params)
    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.2, z_nominal=0.81,
                                             **profile["reference_planner"]))
    goal = (0.351, 3.375)
    planner.set_goal(*goal)
    robot = SimpleRobot(yaw=1.467, z=0.81, tau=0.3, holonomic=True)
    obstacles = [
        Walker("bench_0", (0.163, 1.394), semi_axes=(0.54, 0.165), extent=1.43,
               orientation=2.934),
        Walker("head_on_1", (0.697, 4.482), (-0.051, 0.749), 0.169, 0.0, (0.215, 0.18),
               1.278, -1.769),
        Walker("crossing_2", (-0.646, 2.414), (0.652, 2.245), 0.107, 2.934, (0.218, 0.194),
               1.509, -0.129),
    ]
    goal_closed_loop(cycle, planner, robot, obstacles, 0.0, 30.0)
    return math.hypot(robot.x - goal[0], robot.y - goal[1])
