"""The safety filter's per-cycle logic in closed loop with a lagging robot (no ROS)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filter_harness import ScriptedObstacle, SimpleRobot, body_gap

from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import CycleStatus, SafetyFilterCycle

RATE = 50.0
DT = 1.0 / RATE
Z_NOMINAL = 0.28


def run(cycle, robot, obstacles, reference, duration, hold_height=True):
    """Closed loop; returns per-cycle (t, output, min clearance over obstacles, z)."""
    log = []
    for k in range(int(duration * RATE)):
        t = k * DT
        ref = reference(t, robot) if callable(reference) else reference
        if hold_height:
            ref = VelocityCommand(ref.vx, ref.vy, 2.0 * (Z_NOMINAL - robot.z), ref.yaw_rate)
        out = cycle.step(
            t, ref, t, robot.base_state(t), [o.at(t) for o in obstacles], t
        )
        gaps = [body_gap(robot, o, t, cycle.params) for o in obstacles]
        log.append((t, out, min(gaps) if gaps else math.inf, robot.z))
        for _ in range(10):  # robot integrates at 10x the filter rate
            robot.step(out.command, DT / 10)
    return log


def min_gap(log):
    """Least gap [m] between an obstacle and the protected shape (``body_gap``)."""
    return min(g for _, _, g, _ in log)


BODY_MODELS = pytest.mark.parametrize("body_model", ["body", "point"])


def known_body_failure(request, body_model: str, reason: str) -> None:
    """Mark a whole-body case that fails today (issue #16 open): kept, counted, strict."""
    if body_model == "body":
        request.applymarker(pytest.mark.xfail(strict=True, reason=reason))


@pytest.mark.parametrize(
    "obstacle",
    [
        ScriptedObstacle("static", np.array([3.0, 0.05, 0.5])),
        ScriptedObstacle("head_on", np.array([6.0, 0.0, 0.5]), np.array([-0.4, 0.0, 0.0])),
        ScriptedObstacle("crossing", np.array([3.0, -2.5, 0.5]), np.array([0.0, 0.45, 0.0])),
    ],
    ids=lambda o: o.id,
)
@BODY_MODELS
def test_vertical_obstacle_avoided_with_filter_and_hit_without(obstacle, body_model, request):
    if obstacle.id == "static":
        known_body_failure(request, body_model, "#16: turning in place at rest, the rows "
                           "below v_eps take the reference's direction, which the middle "
                           "circle's sideways motion opposes: h -0.005, RELAXED; h jumps "
                           "(-0.085) where a row's speed crosses v_eps. A continuous branch "
                           "held the robot backing slowly for 16 s instead (tried)")
    if obstacle.id == "head_on":
        known_body_failure(request, body_model, "#16: inside the walker's cone from the "
                           "start, the QP keeps h near 0 by turning the front circle sideways; "
                           "its yaw rate climbs to the limit at ~3 s (RELAXED, h -0.006 below "
                           "h0 exp(-gamma t)). The turning escape (test_turning_escape) then "
                           "keeps the cover out of the walker's circle (no EMERGENCY)")
    params = FilterParams(body_model=body_model)
    ref = VelocityCommand(0.5, 0.0, 0.0, 0.0)
    log = run(SafetyFilterCycle(params), SimpleRobot(), [obstacle], ref, 16.0)
    statuses = {out.status for _, out, *_ in log}
    assert CycleStatus.ACTIVE in statuses
    assert CycleStatus.EMERGENCY_BRAKE not in statuses
    assert min_gap(log) > 0.0, "the protected shape touched the obstacle"
    # A mover may start the run inside the cone (h0 < 0): the CBF condition then guarantees
    # h(t) >= h0 exp(-gamma t); otherwise h stays >= 0 (tolerance: discretisation, robot lag).
    hs = [(t, float(out.result.h.min())) for t, out, *_ in log if out.result.h.size]
    h0 = min(hs[0][1], 0.0)
    assert all(h >= h0 * math.exp(-params.gamma * t) - 1e-3 for t, h in hs)

    baseline = SafetyFilterCycle(params.updated(enabled=False))
    off = run(baseline, SimpleRobot(), [obstacle], ref, 16.0)
    assert {out.status for _, out, *_ in off} == {CycleStatus.PASS_THROUGH}
    assert min_gap(off) < 0.0, "scenario is not a collision course without filter"


@BODY_MODELS
def test_ten_obstacles_never_entered(body_model):
    rng = np.random.default_rng(3)
    obstacles = [
        ScriptedObstacle(
            f"o{i}",
            np.array([rng.uniform(2, 10), rng.uniform(-1.5, 1.5), 0.5]),
            np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0.0]),
            (rng.uniform(0.1, 0.3),) * 2,
        )
        for i in range(10)
    ]
    params = FilterParams(body_model=body_model)
    log = run(SafetyFilterCycle(params), SimpleRobot(), obstacles, VelocityCommand(0.5), 20.0)
    assert min_gap(log) > 0.0


@BODY_MODELS
def test_bar_ahead_ducks_and_rises_again(body_model):
    bar = ScriptedObstacle("bar", np.array([2.5, 0.0, 0.42]), semi_axes=(0.05, 0.05), plane=1,
                           extent=3.0)
    params = FilterParams(body_model=body_model)
    robot = SimpleRobot()
    log = run(SafetyFilterCycle(params), robot, [bar], VelocityCommand(0.4), 16.0)
    # Ducked: the body went down at least 2 cm (the whole body starts early and gently,
    # about -0.01 m/s; the single point later and faster).
    assert min(z for *_, z in log) < Z_NOMINAL - 0.02, "the filter never made it duck"
    assert min_gap(log) > 0.0
    assert robot.x > 3.5, "the robot did not pass under the bar"
    assert abs(robot.z - Z_NOMINAL) < 0.01, "the robot did not regain its height"


@BODY_MODELS
def test_bar_too_low_to_duck_under_brakes_instead(body_model):
    bar = ScriptedObstacle("low", np.array([2.5, 0.0, 0.30]), semi_axes=(0.05, 0.05), plane=1,
                           extent=3.0)
    params = FilterParams(body_model=body_model)
    robot = SimpleRobot()
    log = run(SafetyFilterCycle(params), robot, [bar], VelocityCommand(0.4), 16.0)
    assert min_gap(log) > 0.0
    assert min(z for *_, z in log) > params.min_height - 0.02
    assert robot.x < 2.5


def test_bar_beside_the_robot_is_ignored():
    bar = ScriptedObstacle("aside", np.array([2.5, 3.0, 0.35]), semi_axes=(0.05, 0.05), plane=1,
                           extent=1.0)
    log = run(SafetyFilterCycle(), SimpleRobot(), [bar], VelocityCommand(0.4), 3.0)
    assert all(out.obstacle_ids == [] for _, out, *_ in log)


def test_stale_odometry_and_obstacles_brake_to_zero_at_the_limit():
    params = FilterParams()
    cycle = SafetyFilterCycle(params)
    robot = SimpleRobot()
    ref = VelocityCommand(0.5)
    for k in range(150):  # reach speed
        t = k * DT
        out = cycle.step(t, ref, t, robot.base_state(t), [], t)
        robot.step(out.command, DT)
    v0 = out.command.vx
    assert v0 > 0.4
    t0 = 150 * DT
    for what in ("odom", "obstacles"):
        c = SafetyFilterCycle(params)
        c.step(t0 - DT, ref, t0 - DT, robot.base_state(t0 - DT), [], t0 - DT)
        c._v[0] = v0  # same speed as above
        speeds = []
        for k in range(60):
            t = t0 + k * DT
            base = robot.base_state(t0 - 1.0 if what == "odom" else t)
            obs_time = t0 - 1.0 if what == "obstacles" else t
            out = c.step(t, ref, t, base, [], obs_time)
            assert out.status is CycleStatus.STALE_INPUT, what
            assert what in out.text or (what == "odom" and "odometry" in out.text)
            speeds.append(out.command.vx)
        decel = -np.diff(speeds) / DT
        assert decel.max() <= params.brake_decel + 1e-9
        assert speeds[-1] == 0.0


def test_never_received_inputs_are_stale():
    out = SafetyFilterCycle().step(0.0, VelocityCommand(0.5), 0.0, None, None, None)
    assert out.status is CycleStatus.STALE_INPUT
    assert out.command.is_zero()


def test_stale_reference_becomes_zero():
    cycle = SafetyFilterCycle()
    robot = SimpleRobot(vx=0.5)
    cycle.step(0.0, VelocityCommand(0.5), 0.0, robot.base_state(0.0), [], 0.0)
    for k in range(1, 200):
        t = k * DT
        out = cycle.step(t, VelocityCommand(0.5), 0.0, robot.base_state(t), [], t)
        robot.step(out.command, DT)
    assert out.reference_stale and out.reference.is_zero()
    assert "reference stale" in out.text
    assert abs(out.command.vx) < 1e-3


@BODY_MODELS
def test_inside_an_obstacle_brakes_and_gets_out(body_model):
    params = FilterParams(body_model=body_model)
    cycle = SafetyFilterCycle(params)
    robot = SimpleRobot(vx=0.3)
    inside = ScriptedObstacle("here", np.array([0.35, 0.0, 0.5]), semi_axes=(0.2, 0.2))
    assert body_gap(robot, inside, 0.0, params) < 0.0
    emergency_speeds = []
    for k in range(int(10.0 * RATE)):  # the whole body starts deeper inside than one point
        t = k * DT
        out = cycle.step(t, VelocityCommand(0.5), t, robot.base_state(t), [inside.at(t)], t)
        if out.status is CycleStatus.EMERGENCY_BRAKE:
            emergency_speeds.append(out.command.vx)
            assert "obstacle(s) [0]" in out.text
        elif emergency_speeds:
            break
        robot.step(out.command, DT)
    assert emergency_speeds, "never flagged EMERGENCY_BRAKE"
    # It brakes while it would go deeper; once it is leaving, it keeps leaving (#14).
    assert min(emergency_speeds) < 0.3, "did not brake"
    assert out.status is not CycleStatus.EMERGENCY_BRAKE, "never got out"
    assert body_gap(robot, inside, t, params) > 0.0


def test_infeasible_constraints_give_a_flagged_relaxed_solution():
    params = FilterParams(max_accel=0.05, max_yaw_accel=0.05, max_vertical_accel=0.05,
                          windup_band=10.0)
    cycle = SafetyFilterCycle(params)
    robot = SimpleRobot(vx=0.8)
    wall = ScriptedObstacle("wall", np.array([1.2, 0.0, 0.5]), semi_axes=(0.3, 0.3))
    cycle.step(0.0, VelocityCommand(0.8), 0.0, robot.base_state(0.0), [wall.at(0.0)], 0.0)
    out = cycle.step(DT, VelocityCommand(0.8), DT, robot.base_state(DT), [wall.at(DT)], DT)
    assert out.status is CycleStatus.RELAXED
    assert out.result.slack.max() > 0
    assert np.all(np.isfinite(out.u_safe))


def test_pass_through_forwards_the_reference_exactly():
    cycle = SafetyFilterCycle(FilterParams(enabled=False))
    ref = VelocityCommand(0.7, 0.1, -0.05, 0.3)
    out = cycle.step(1.0, ref, 1.0, None, None, None)
    assert out.status is CycleStatus.PASS_THROUGH
    assert out.command == ref


def test_unicycle_model_never_passes_on_a_side_step():
    cycle = SafetyFilterCycle()
    robot = SimpleRobot()
    for k in range(20):
        t = k * DT
        out = cycle.step(t, VelocityCommand(0.3, 0.2, 0.0, 0.0), t, robot.base_state(t), [], t)
    assert out.command.vy == 0.0


@BODY_MODELS
def test_holonomic_model_side_steps_around_an_obstacle(body_model):
    params = FilterParams(body_model=body_model, model="holonomic", offset=0.0)
    obstacle = ScriptedObstacle("static", np.array([3.0, 0.05, 0.5]))
    log = run(SafetyFilterCycle(params), SimpleRobot(holonomic=True), [obstacle],
              VelocityCommand(0.5), 16.0)
    assert min_gap(log) > 0.0
    assert any(abs(out.command.vy) > 0.02 for _, out, *_ in log)


@pytest.mark.parametrize(
    "change, fragment",
    [
        ({"gamma": -1.0}, "gamma"),
        ({"rate": 0.0}, "rate"),
        ({"model": "tank"}, "model"),
        ({"min_height": 0.5}, "min_height"),
        ({"weights": (1.0, 0.0, 1.0)}, "weights"),
        ({"robot_width": float("nan")}, "robot_width"),
        ({"no_such": 1.0}, "no_such"),
    ],
)
def test_invalid_parameters_are_rejected_with_the_reason(change, fragment):
    with pytest.raises(ValueError, match=fragment):
        FilterParams().updated(**change)


def test_repeated_or_backward_time_stamps_stay_finite():
    cycle = SafetyFilterCycle()
    robot = SimpleRobot(vx=0.3)
    wall = ScriptedObstacle("w", np.array([2.0, 0.0, 0.5]))
    for t in (1.0, 1.0, 0.5, 0.5):  # same stamp twice, then back in time
        out = cycle.step(t, VelocityCommand(0.5), t, robot.base_state(t), [wall.at(t)], t)
        assert out.status is not CycleStatus.INVALID_INPUT, out.text
        assert np.all(np.isfinite(out.command.as_array()))


def _walk_to_goal_past_a_pillar(deadlock_yaw_rate: float, lateral: float, body_model: str):
    """Goal planner -> cycle -> robot from rest, a pillar 1.7 m dead ahead; (log, robot)."""
    from safe_legged_c3bf.planning.reference_planner import (
        PlannerConfig,
        ReferencePlanner,
        RobotPose,
    )

    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.4))
    planner.set_goal(6.0, 0.0)

    def reference(t, robot):
        return planner.compute(RobotPose(robot.x, robot.y, robot.yaw, robot.z), t)

    params = FilterParams(deadlock_yaw_rate=deadlock_yaw_rate, body_model=body_model)
    pillar = ScriptedObstacle("pillar", np.array([1.7, lateral, 0.5]), semi_axes=(0.25, 0.25))
    robot = SimpleRobot(tau=0.15)
    return run(SafetyFilterCycle(params), robot, [pillar], reference, 25.0), robot


@pytest.mark.parametrize("lateral", [-0.1, -0.05, 0.0, 0.05, 0.1])
def test_deadlock_in_front_of_a_pillar_is_resolved_by_turning(lateral):
    body_model = "point"  # the deadlock turn is the point model's; the body model steers
    # Without the deadlock turn the robot stands in front of the pillar for most of the run (at
    # rest h = 0 and the QP can only brake: a stable equilibrium of the CBF-QP) and is still
    # > 1 m from the goal after 25 s; with it, it arrives (about 20 s; 15.5 s without pillar).
    log, robot = _walk_to_goal_past_a_pillar(0.0, lateral, body_model)
    assert math.hypot(robot.x - 6.0, robot.y) > 1.0
    log, robot = _walk_to_goal_past_a_pillar(0.5, lateral, body_model)
    assert math.hypot(robot.x - 6.0, robot.y) < 0.3, (robot.x, robot.y)
    assert min_gap(log) > 0.0
    assert any("deadlock" in out.text for _, out, *_ in log)


def _between_three_obstacles(deadlock_yaw_rate: float, body_model: str):
    """Random quadruped seed 7 at t = 25 s: at rest between two pillars and a stopped mover,
    facing away from the goal; the planner turns in place (right, the short way) and that
    turn swings the body point towards a pillar."""
    from safe_legged_c3bf.planning.reference_planner import (
        PlannerConfig,
        ReferencePlanner,
        RobotPose,
    )

    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.4))
    planner.set_goal(-1.03, 6.35)

    def reference(t, robot):
        return planner.compute(RobotPose(robot.x, robot.y, robot.yaw, robot.z), t)

    obstacles = [
        ScriptedObstacle("pillar_0", np.array([-0.32, 2.48, 0.5]), semi_axes=(0.316, 0.248)),
        ScriptedObstacle("pillar_2", np.array([-0.64, 4.89, 0.5]), semi_axes=(0.214, 0.16)),
        ScriptedObstacle("mover", np.array([0.89, 3.93, 0.5]), semi_axes=(0.286, 0.259)),
    ]
    robot = SimpleRobot(x=0.62, y=3.24, yaw=math.radians(-113.0), tau=0.15)
    params = FilterParams(deadlock_yaw_rate=deadlock_yaw_rate, body_model=body_model)
    return run(SafetyFilterCycle(params), robot, obstacles, reference, 30.0), robot


@pytest.mark.parametrize("lateral", [-0.1, -0.05, 0.0, 0.05, 0.1])
def test_whole_body_steers_past_a_pillar_dead_ahead_from_rest(lateral):
    """Cone steering turns the reference out of the cone: at the goal, no deadlock turn."""
    log, robot = _walk_to_goal_past_a_pillar(0.0, lateral, "body")
    assert math.hypot(robot.x - 6.0, robot.y) < 0.3, (robot.x, robot.y)
    assert min_gap(log) > 0.0
    assert any("steering" in out.text for _, out, *_ in log)


def test_deadlock_of_a_blocked_turn_in_place_is_resolved():
    """The single point's deadlock turn (the whole body has none: next test)."""
    log, robot = _between_three_obstacles(0.0, "point")
    assert math.hypot(robot.x - 0.62, robot.y - 3.24) < 0.05  # stood still for 30 s
    log, robot = _between_three_obstacles(0.5, "point")
    assert math.hypot(robot.x + 1.03, robot.y - 6.35) < 0.3, (robot.x, robot.y)
    assert min_gap(log) > 0.0
    assert any("deadlock" in out.text for _, out, *_ in log)


@pytest.mark.xfail(strict=True, reason="#16: with the plain unicycle (no side-step) a RELAXED "
                   "spell, then the EMERGENCY back-out while turning, bring the front body "
                   "circle ~1 mm into the stopped mover's circle")
def test_whole_body_leaves_three_obstacles_without_a_deadlock_turn():
    """The whole body steers out of the same spot (no deadlock turn) and never touches."""
    log, robot = _between_three_obstacles(0.0, "body")
    assert math.hypot(robot.x + 1.03, robot.y - 6.35) < 0.3, (robot.x, robot.y)
    assert min_gap(log) > 0.0


def _through_a_doorway(params: FilterParams):
    """Goal planner -> cycle -> robot from rest towards a 0.6 m doorway between two pillars.

    The doorway (y from -0.1 to 0.5 m at x = 3 m) leaves the A1's cover 4.9 cm a side with
    the safety margin: less than the tie-break's 6 cm on one side. Returns the robot and its
    mean y while its base crossed x = 3 m.
    """
    from safe_legged_c3bf.planning.reference_planner import (
        PlannerConfig,
        ReferencePlanner,
        RobotPose,
    )

    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.4))
    planner.set_goal(6.0, 0.2)
    crossing = []

    def reference(t, robot):
        if abs(robot.x - 3.0) < 0.02:
            crossing.append(robot.y)
        return planner.compute(RobotPose(robot.x, robot.y, robot.yaw, robot.z), t)

    pillars = [ScriptedObstacle("right", np.array([3.0, -0.3, 0.5]), semi_axes=(0.2, 0.2)),
               ScriptedObstacle("left", np.array([3.0, 0.7, 0.5]), semi_axes=(0.2, 0.2))]
    robot = SimpleRobot(y=0.2, tau=0.15, holonomic=params.model != "unicycle")
    log = run(SafetyFilterCycle(params), robot, pillars, reference, 25.0)
    assert min_gap(log) > 0.0
    assert math.hypot(robot.x - 6.0, robot.y - 0.2) < 0.3, (robot.x, robot.y)
    return float(np.mean(crossing))


@pytest.mark.parametrize("model", ["unicycle", "unicycle_lateral"])
def test_the_tie_break_as_a_margin_for_movers_leaves_a_doorway_open(model):
    """With the cone steering choosing sides, static pillars keep no tie-break: it fits through.

    In full on the pillars (tie_break_speed 0) the tie-break closes the doorway and the robot
    walks round the left pillar; as a margin for movers only, it walks through.
    """
    body = FilterParams(body_model="body", model=model, gamma=2.0)
    assert abs(_through_a_doorway(body.updated(tie_break_speed=0.1)) - 0.2) < 0.05
    assert _through_a_doorway(body.updated(tie_break_speed=0.0)) > 0.9  # round the left pillar


def test_the_tie_break_stays_in_full_without_the_cone_steering():
    """The single point (and a whole body with the steering off) keeps the tie-break in full:
    nothing else would choose a side of a static obstacle dead ahead."""
    for params, steers in [
        (FilterParams(body_model="body", model="unicycle"), True),
        (FilterParams(body_model="point", model="unicycle"), False),
        (FilterParams(body_model="body", model="unicycle", steer_horizon=0.0), False),
        (FilterParams(body_model="body", model="holonomic"), False),
    ]:
        cycle = SafetyFilterCycle(params.updated(tie_break_speed=0.1))
        assert cycle.shaping.steers is steers
        pillar = ScriptedObstacle("pillar", np.array([3.0, 0.0, 0.5]))
        robot = SimpleRobot()
        out = cycle.step(0.0, VelocityCommand(0.5), 0.0, robot.base_state(0.0),
                         [pillar.at(0.0)], 0.0)
        full = SafetyFilterCycle(params.updated(tie_break_speed=0.0)).step(
            0.0, VelocityCommand(0.5), 0.0, robot.base_state(0.0), [pillar.at(0.0)], 0.0)
        # h at rest is 0 either way; the clearance tells the circle's size
        same = math.isclose(out.result.clearance.min(), full.result.clearance.min())
        assert same is not steers, params
