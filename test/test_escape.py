"""Escape shaping (``safety/escape.py``): a mover on course for a standing robot is escaped.

Unit cases on the stage alone, then the closed loop (no ROS) of random biped seed 8's case: a
walker coming head on at twice the biped's reverse speed, a robot that answers its commands
with a 0.5 s lag. The QP alone backs away too slowly and turns its retreat sideways into the
walker's path; with the stage the cover stays clear.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from filter_harness import ScriptedObstacle, SimpleRobot
from test_safety_cycle import min_gap, run

from safe_legged_c3bf.c3bf.body import robot_body
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.escape import EscapeShaping
from safe_legged_c3bf.safety.input_bounds import yaw_rate_only_decays
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle
from safe_legged_c3bf.safety.velocity_obstacles import closest_clearances, first_contact_times

LIMITS = (0.2, 0.1, 0.08)  # the biped's forward, reverse and side-step speeds [m/s]


def _stage() -> EscapeShaping:
    return EscapeShaping.for_body(robot_body("biped"), 6.0)


def _head_on(distance: float = 1.1, speed: float = 0.2):
    """Centres, velocities, radii of one walker ahead of a robot at the origin facing +x."""
    return np.array([[distance, 0.0]]), np.array([[-speed, 0.0]]), np.array([0.30])


def _random_pairs(seed: int, pairs: int, velocities: int):
    """Random pairs (centre offsets p, obstacle velocities w, contact radii) and velocities."""
    rng = np.random.default_rng(seed)
    return (rng.uniform(-2.0, 2.0, (pairs, 2)), rng.uniform(-0.5, 0.5, (pairs, 2)),
            rng.uniform(0.2, 0.6, pairs), rng.uniform(-0.5, 0.5, (velocities, 2)))


def test_first_contact_times_match_sampling():
    p, w, radius, vel = _random_pairs(3, 6, 40)
    times = first_contact_times(vel, p, w, radius, 5.0)
    ts = np.arange(0.0, 5.0, 1e-3)
    for k in range(len(vel)):
        rel = p[None] + ts[:, None, None] * (w - vel[k])[None]  # (t, m, 2)
        inside = (np.linalg.norm(rel, axis=-1) <= radius).any(axis=1)
        start_inside = (np.linalg.norm(p, axis=-1) <= radius)
        if start_inside.any():
            continue  # contact at t = 0 is decided by closing in, checked below
        expected = ts[np.argmax(inside)] if inside.any() else math.inf
        assert times[k] == pytest.approx(expected, abs=2e-3)


def test_closest_clearances_match_sampling():
    p, w, radius, vel = _random_pairs(4, 5, 30)
    got = closest_clearances(vel, p, w, radius, 4.0)
    ts = np.arange(0.0, 4.0 + 1e-9, 1e-3)
    for k in range(len(vel)):
        rel = p[None] + ts[:, None, None] * (w - vel[k])[None]  # (t, m, 2)
        expected = (np.linalg.norm(rel, axis=-1) - radius).min()
        assert got[k] == pytest.approx(expected, abs=1e-6)
    assert np.isinf(closest_clearances(vel, p[:0], w[:0], radius[:0], 4.0)).all()


def test_a_pair_in_contact_counts_only_while_it_closes_in():
    p, w, r = np.array([[0.2, 0.0]]), np.zeros((1, 2)), np.array([0.3])
    closing = first_contact_times(np.array([[0.1, 0.0]]), p, w, r, 5.0)
    leaving = first_contact_times(np.array([[-0.1, 0.0]]), p, w, r, 5.0)
    assert closing[0] == 0.0
    assert math.isinf(leaving[0])


def test_standing_still_safe_means_no_escape():
    stage = _stage()
    # A static pillar touching distance ahead, with a tracked velocity's noise: no mover.
    pillar = (np.array([[0.6, 0.0]]), np.array([[-0.03, 0.0]]), np.array([0.3]))
    assert stage.shape((0.0, 0.0), 0.0, (0.2, 0.0), *pillar, LIMITS) is None
    # A walker crossing well ahead: standing still, it passes.
    crossing = (np.array([[2.0, -2.0]]), np.array([[0.0, 0.4]]), np.array([0.3]))
    assert stage.shape((0.0, 0.0), 0.0, (0.2, 0.0), *crossing, LIMITS) is None


def test_a_head_on_walker_is_escaped_away_and_aside_within_the_limits():
    stage = _stage()
    out = stage.shape((0.0, 0.0), 0.0, (0.2, 0.0), *_head_on(), LIMITS)
    assert out is not None
    assert out.vx <= 1e-9, "never towards the walker"
    assert -LIMITS[1] - 1e-9 <= out.vx and abs(out.vy) <= LIMITS[2] + 1e-9
    assert abs(out.vy) > 0.05, "it steps aside: backing alone is slower than the walker"


def test_a_robot_already_touching_a_walker_coming_at_it_steps_out_of_its_path():
    """Random biped seed 11 with sensors: the walker was known to move only once the biped's
    cover touched its circle. Every velocity then met it at once (first contact 0 s), and the
    tie went to the velocity nearest the forward reference: forward and sideways, into the
    walker's path. Among equals the stage now keeps the most clearance at closest approach."""
    stage = _stage()
    # the walker 0.05 m to the left of the robot's line, already within contact distance
    centres, vel, radii = np.array([[0.45, 0.05]]), np.array([[-0.24, 0.0]]), np.array([0.30])
    out = stage.shape((0.0, 0.0), 0.0, (0.19, 0.0), centres, vel, radii, LIMITS)
    assert out is not None and out.contact_time == 0.0
    assert out.vx <= 1e-9, "never towards the walker"
    assert out.vy < -0.05, "to the right: out of the walker's path"


def test_a_clear_escape_is_the_one_nearest_the_reference():
    stage = _stage()
    centres, vel, radii = _head_on(distance=1.5, speed=0.3)
    out = stage.shape((0.0, 0.0), 0.0, (0.0, 0.08), centres, vel, radii, (0.8, 0.8, 0.5))
    assert math.isinf(out.contact_time)
    assert out.vy > 0.0, "the reference's side"
    # Rotating the whole scene and the robot by 90 deg gives the same body-frame answer.
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])
    turned = stage.shape((0.0, 0.0), math.pi / 2, (0.0, 0.08), centres @ rot.T, vel @ rot.T,
                         radii, (0.8, 0.8, 0.5))
    assert (turned.vx, turned.vy) == pytest.approx((out.vx, out.vy), abs=1e-9)


def test_no_body_or_no_horizon_means_no_stage():
    assert EscapeShaping.for_body(None, 6.0) is None
    assert EscapeShaping.for_body(robot_body("a1"), 0.0) is None


@pytest.mark.parametrize("wz", [0.3, -0.3, 0.0])
def test_the_yaw_rate_only_decays(wz):
    lo, hi = np.array([-1.0, -0.8, -1.0]), np.array([1.0, 0.8, 1.0])
    yaw_rate_only_decays(lo, hi, wz, 0.02, (0, 3, 2))
    assert lo[1] <= hi[1]
    for alpha in (lo[1], hi[1]):
        assert abs(wz + alpha * 0.02) <= abs(wz) + 1e-12
    assert (lo[[0, 2]] == -1.0).all() and (hi[[0, 2]] == 1.0).all()


def _biped_filter(**kw) -> FilterParams:
    return FilterParams(
        model="unicycle_lateral", body_model="body", robot_body="biped", offset=0.2,
        weights=(1.0, 0.05, 0.5), max_speed=0.2, max_reverse_speed=0.1,
        max_lateral_speed=0.08, max_yaw_rate=0.4, max_accel=0.3, brake_decel=0.3,
        max_yaw_accel=0.8, min_height=0.7, max_height=0.9, **kw,
    )


def _walker_at_twice_the_reverse_speed(escape_horizon: float):
    walker = ScriptedObstacle("walker", np.array([1.1, 0.0, 0.6]), np.array([-0.2, 0.0, 0.0]),
                              semi_axes=(0.25, 0.19))
    robot = SimpleRobot(holonomic=True, tau=0.5, z=0.81)
    cycle = SafetyFilterCycle(_biped_filter(escape_horizon=escape_horizon))
    return run(cycle, robot, [walker], VelocityCommand(0.2, 0.0, 0.0, 0.0), 12.0)


def test_a_walker_at_twice_the_reverse_speed_is_escaped():
    log = _walker_at_twice_the_reverse_speed(6.0)
    assert min_gap(log) > 0.02, "the cover touched the walker's circle"
    assert any("escaping a mover" in out.text for _, out, *_ in log)


def test_without_the_stage_the_qp_alone_lets_that_walker_touch():
    """The case needs the stage: the QP alone (escape_horizon 0) is too slow and turns."""
    assert min_gap(_walker_at_twice_the_reverse_speed(0.0)) < 0.0


def test_a_reference_whose_own_path_is_clear_is_kept():
    """A walker crossing towards where the robot stands, but the robot passes ahead of it."""
    stage = _stage()
    crossing = (np.array([[0.4, -1.2]]), np.array([[0.0, 0.3]]), np.array([0.2]))
    assert stage.shape((0.0, 0.0), 0.0, (0.0, 0.0), *crossing, (0.8, 0.3, 0.3)) is not None
    assert stage.shape((0.0, 0.0), 0.0, (0.8, 0.0), *crossing, (0.8, 0.3, 0.3)) is None


@pytest.mark.xfail(strict=True, reason=(
    "#16: random biped seed 11 (oracle), from its colliding runs' state when the walker "
    "starts. From 8.5 s the cover is inside the walker's inflated circle, and the emergency "
    "backs the biped away from the walker's centre at its limits (-0.1, -0.08 m/s in "
    "base_link): within 20 deg of the walker's own path, at 0.13 m/s against the walker's "
    "0.24 m/s. The cover ends 0.18 m inside the walker's circle at ~12.2 s (README, "
    "session 31)"))
def test_the_biped_of_random_seed_11_keeps_clear_of_a_walker_starting_beside_it():
    """At 7.0 s the biped walks at 0.2 m/s on a path passing 0.58 m from a standing walker's
    centre, 0.9 m away; at 7.28 s the walker walks at it at 0.24 m/s (its path 0.28 m from
    the biped's centre) for 2.1 m. The biped's cover stays out of the walker's circle."""
    from filter_harness import Walker, body_gap, goal_closed_loop

    from safe_legged_c3bf.planning.reference_planner import PlannerConfig, ReferencePlanner
    from safe_legged_c3bf.run.parameters import robot_profile

    profile = robot_profile("biped")
    params = FilterParams(**profile["safety_filter"]).updated(  # the scenario's filter section
        max_reverse_speed=0.1, max_yaw_accel=0.8, min_height=0.7, max_height=0.9)
    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.2, z_nominal=0.81,
                                             **profile["reference_planner"]))
    planner.set_goal(-2.746, 1.484)
    robot = SimpleRobot(x=-0.44, y=0.646, yaw=2.523, z=0.81, vx=0.198, vy=-0.018, wz=-0.015,
                        tau=0.3, holonomic=True)
    walker = Walker("oblique_0", (-1.391, 0.565), (0.562, 1.419), 0.239, 7.279,
                    (0.252, 0.241), 1.236, 0.412)
    pillar = Walker("pillar_1", (-1.869, 0.996), semi_axes=(0.204, 0.135), extent=1.538,
                    orientation=1.74)
    gaps = []
    goal_closed_loop(SafetyFilterCycle(params), planner, robot, [walker, pillar], 7.0, 6.0,
                     lambda t: gaps.append(body_gap(robot, walker, t, params)))
    assert min(gaps) >= 0.0, f"the cover came {-min(gaps):.3f} m into the walker's circle"
