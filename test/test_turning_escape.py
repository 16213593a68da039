"""The plain unicycle's escape from movers (``safety/turning_escape.py``): turn, then go.

Unit cases on the stage alone (its plan checked by sampling the turn and the straight path
after it), then the closed loop (no ROS) of a head-on walker that the QP alone let reach the
whole body's cover.
"""

from __future__ import annotations

import math

import numpy as np
from filter_harness import ScriptedObstacle, SimpleRobot
from test_safety_cycle import min_gap, run

from safe_legged_c3bf.c3bf.body import robot_body
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import CycleStatus, SafetyFilterCycle
from safe_legged_c3bf.safety.turning_escape import TurningEscapeShaping
from safe_legged_c3bf.safety.velocity_obstacles import (
    closest_clearances,
    closest_clearances_batched,
    contact_times_batched,
    first_contact_times,
)

LIMITS = (0.8, 0.3, 1.0, 4.0)  # the filter's defaults: forward, reverse, yaw rate, yaw accel
HORIZON = 6.0


def _stage() -> TurningEscapeShaping:
    return TurningEscapeShaping.for_body(robot_body("a1"), HORIZON)


def _cover():
    offsets, radii, planes = robot_body("a1").arrays
    return offsets[planes == 0, :2], radii[planes == 0]


def _plan_clearance(pos, yaw, heading, speed, centers, velocities, radii) -> float:
    """Least clearance [m] of the cover over the horizon along the plan, sampled every 10 ms.

    The turn at the yaw-rate limit (reached at the yaw acceleration limit), standing, then
    straight at ``speed`` along the new heading.
    """
    _, _, rate, accel = LIMITS
    turn = abs(heading) / rate + (rate / accel if heading else 0.0)
    offsets, cover_r = _cover()
    least = math.inf
    for t in np.arange(0.0, HORIZON, 0.01):
        psi = yaw + heading * min(t / turn, 1.0) if turn else yaw
        go = max(t - turn, 0.0) * speed
        base = np.asarray(pos) + go * np.array([math.cos(psi), math.sin(psi)])
        c, s = math.cos(psi), math.sin(psi)
        points = base + offsets @ np.array([[c, s], [-s, c]])
        obst = centers + t * velocities
        d = np.linalg.norm(points[:, None] - obst[None], axis=-1) - cover_r[:, None] - radii
        least = min(least, float(d.min()))
    return least


def test_batched_velocity_obstacles_equal_one_batch_at_a_time():
    rng = np.random.default_rng(2)
    vel, p = rng.uniform(-0.5, 0.5, (4, 7, 2)), rng.uniform(-2.0, 2.0, (4, 5, 2))
    w, radius = rng.uniform(-0.4, 0.4, (5, 2)), rng.uniform(0.2, 0.6, 5)
    horizon = np.array([0.5, 2.0, 6.0, -1.0])
    times = contact_times_batched(vel, p, w, radius, horizon)
    closest = closest_clearances_batched(vel, p, w, radius, horizon)
    for b in range(4):
        assert np.array_equal(times[b], first_contact_times(vel[b], p[b], w, radius, horizon[b]))
        np.testing.assert_allclose(
            closest[b], closest_clearances(vel[b], p[b], w, radius, max(horizon[b], 0.0)))
    assert np.isinf(times[3]).all()


def test_no_mover_or_a_clear_standstill_means_no_escape():
    stage = _stage()
    pillar = (np.array([[0.9, 0.0]]), np.array([[0.02, 0.0]]), np.array([0.3]))
    assert stage.shape((0.0, 0.0), 0.0, 0.5, 0.0, *pillar, LIMITS) is None  # noise: no mover
    passing = (np.array([[2.0, 3.0]]), np.array([[0.0, 0.4]]), np.array([0.3]))
    assert stage.shape((0.0, 0.0), 0.0, 0.5, 0.0, *passing, LIMITS) is None  # moving away


def test_a_head_on_walker_is_escaped_by_a_turn_whose_plan_stays_clear():
    stage = _stage()
    walker = (np.array([[2.4, 0.0]]), np.array([[-0.6, 0.0]]), np.array([0.30]))
    out = stage.shape((0.0, 0.0), 0.0, 0.5, 0.0, *walker, LIMITS)
    assert out is not None and math.isinf(out.contact_time)
    assert abs(out.heading) >= math.radians(20.0)  # faster than the robot backs away
    assert _plan_clearance((0.0, 0.0), 0.0, 0.0, -LIMITS[1], *walker) < 0.0
    assert _plan_clearance((0.0, 0.0), 0.0, out.heading, out.vx, *walker) > -0.01
    # Standing still, or walking on at the present heading, meets the walker.
    assert _plan_clearance((0.0, 0.0), 0.0, 0.0, 0.0, *walker) < 0.0
    assert _plan_clearance((0.0, 0.0), 0.0, 0.0, 0.5, *walker) < 0.0


def test_the_turn_itself_may_not_sweep_the_cover_into_a_pillar():
    """A pillar at the front right: turning right would swing the front into it; go left
    (without it, the tie between the two sides goes to the right)."""
    stage = _stage()
    centers = np.array([[2.4, 0.0], [0.35, -0.55]])
    velocities = np.array([[-0.6, 0.0], [0.0, 0.0]])
    radii = np.array([0.30, 0.25])
    alone = stage.shape((0.0, 0.0), 0.0, 0.5, 0.0, centers[:1], velocities[:1], radii[:1],
                        LIMITS)
    assert alone is not None and alone.heading < 0.0
    out = stage.shape((0.0, 0.0), 0.0, 0.5, 0.0, centers, velocities, radii, LIMITS)
    assert out is not None and out.heading > 0.0
    assert _plan_clearance((0.0, 0.0), 0.0, out.heading, out.vx, centers, velocities,
                           radii) > -0.01


def test_plans_are_clear_when_said_clear_over_random_cases():
    """Sampling check: every plan the stage calls clear keeps the cover out (1 cm), the turn
    included: static pillars stand close round the robot, where a turn sweeps its ends."""
    stage, rng, clear = _stage(), np.random.default_rng(5), 0
    for _ in range(60):
        n = int(rng.integers(1, 4))
        angle = rng.uniform(-math.pi, math.pi, n)
        centers = rng.uniform(0.45, 0.8, n)[:, None] * np.stack([np.cos(angle),
                                                                  np.sin(angle)], -1)
        radii = rng.uniform(0.1, 0.3, n)
        walker = rng.uniform(1.8, 3.0) * np.array([1.0, rng.uniform(-0.2, 0.2)])
        centers = np.vstack([walker, centers])
        velocities = np.vstack([-walker / np.linalg.norm(walker) * rng.uniform(0.4, 0.6),
                                np.zeros((n, 2))])
        radii = np.concatenate([[0.3], radii])
        if _plan_clearance((0.0, 0.0), 0.0, 0.0, 0.0, centers[1:], velocities[1:],
                           radii[1:]) < 0.0:
            continue  # a pillar already touching: nothing to check by sampling
        out = stage.shape((0.0, 0.0), 0.0, 0.5, 0.0, centers, velocities, radii, LIMITS)
        if out is None or not math.isinf(out.contact_time):
            continue
        clear += 1
        assert _plan_clearance((0.0, 0.0), 0.0, out.heading, out.vx, centers, velocities,
                               radii) > -0.01, (centers, velocities, radii, out)
    assert clear >= 10


def test_closed_loop_head_on_walker_never_reaches_the_plain_unicycle_body():
    """A walker from 6 m at 0.4 m/s on the A1's path (``test_safety_cycle``'s head-on case):
    with the stage the cover stays out of its circle; without it, EMERGENCY inside."""
    walker = ScriptedObstacle("head_on", np.array([6.0, 0.0, 0.5]), np.array([-0.4, 0.0, 0.0]))
    ref = VelocityCommand(0.5, 0.0, 0.0, 0.0)
    with_stage = FilterParams(body_model="body", model="unicycle")
    log = run(SafetyFilterCycle(with_stage), SimpleRobot(), [walker], ref, 16.0)
    assert min_gap(log) > 0.05
    assert CycleStatus.EMERGENCY_BRAKE not in {out.status for _, out, *_ in log}
    assert any("escaping a mover: turn" in out.text for _, out, *_ in log)
    without = with_stage.updated(escape_horizon=0.0)
    log = run(SafetyFilterCycle(without), SimpleRobot(), [walker], ref, 16.0)
    assert CycleStatus.EMERGENCY_BRAKE in {out.status for _, out, *_ in log}
