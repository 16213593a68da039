"""Tests of the reference velocity planner, in closed loop with kinematic robots."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safe_legged_c3bf.interfaces.rotations import wrap_angle
from safe_legged_c3bf.planning.reference_planner import (
    Goal,
    PlannerConfig,
    PlannerStatus,
    ReferencePlanner,
    RobotPose,
    VelocityCommand,
    validate_goal,
)

DT = 0.02
EPS = 1e-12
HEADINGS = [2 * math.pi * k / 12 for k in range(12)]
GOALS = [
    Goal(2.0, 0.0),
    Goal(-1.5, 1.0),
    Goal(0.3, -0.4),
    Goal(3.0, 3.0, math.pi / 2),
    Goal(-2.0, -2.0, -2.5),
]


def step(pose, cmd, holonomic):
    """Integrate a unicycle (vx, yaw_rate) or holonomic (vx, vy, yaw_rate) robot for DT."""
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    vy = cmd.vy if holonomic else 0.0
    return RobotPose(
        pose.x + (cmd.vx * c - vy * s) * DT,
        pose.y + (cmd.vx * s + vy * c) * DT,
        wrap_angle(pose.yaw + cmd.yaw_rate * DT),
        pose.z + cmd.vz * DT,
    )


def check_limits(cfg, cmd, prev=None, holonomic=False):
    assert -cfg.max_vx - EPS <= cmd.vx <= cfg.max_vx + EPS
    if holonomic:
        assert cmd.vx >= -cfg.max_vx_backward - EPS
        assert abs(cmd.vy) <= cfg.max_vy + EPS
    else:
        assert cmd.vx >= -EPS and cmd.vy == 0.0  # a unicycle never reverses or strafes
    assert abs(cmd.vz) <= cfg.max_vz + EPS
    assert abs(cmd.yaw_rate) <= cfg.max_yaw_rate + EPS
    if prev is not None and cfg.max_linear_accel is not None:
        dv = cfg.max_linear_accel * DT + 1e-9
        assert abs(cmd.vx - prev.vx) <= dv and abs(cmd.vy - prev.vy) <= dv
        assert abs(cmd.vz - prev.vz) <= dv
    if prev is not None and cfg.max_yaw_accel is not None:
        assert abs(cmd.yaw_rate - prev.yaw_rate) <= cfg.max_yaw_accel * DT + 1e-9


def run_to_goal(cfg, start, goal, holonomic, max_time=40.0, hold_time=3.0):
    """Closed loop until arrival, then ``hold_time`` more; returns (pose, arrival_time)."""
    planner = ReferencePlanner(cfg)
    ok, reason = planner.set_goal(goal.x, goal.y, goal.yaw, frame_id="odom")
    assert ok, reason
    pose, prev, arrived_at = start, None, None
    t = 0.0
    while t < max_time:
        cmd = planner.compute(pose, t)
        check_limits(cfg, cmd, prev, holonomic)
        if arrived_at is None and planner.status is PlannerStatus.ARRIVED:
            arrived_at = t
        if arrived_at is not None:
            # Stays stopped at the goal.
            assert planner.status is PlannerStatus.ARRIVED
            assert math.hypot(goal.x - pose.x, goal.y - pose.y) <= cfg.goal_tolerance + 1e-3
            if goal.yaw is not None:
                assert abs(wrap_angle(goal.yaw - pose.yaw)) <= cfg.yaw_tolerance + 1e-3
            if cfg.max_linear_accel is None:
                assert (cmd.vx, cmd.vy, cmd.yaw_rate) == (0.0, 0.0, 0.0)
            if t - arrived_at >= hold_time:
                break
        pose = step(pose, cmd, holonomic)
        prev = cmd
        t += DT
    assert arrived_at is not None, f"did not arrive: {pose} -> {goal}"
    assert (cmd.vx, cmd.vy, cmd.yaw_rate) == (0.0, 0.0, 0.0)
    return pose, arrived_at


@pytest.mark.parametrize("holonomic", [False, True], ids=["unicycle", "holonomic"])
@pytest.mark.parametrize("goal", GOALS, ids=lambda g: f"goal({g.x},{g.y},{g.yaw})")
def test_reaches_goal_from_every_heading(goal, holonomic):
    cfg = PlannerConfig(mode="holonomic" if holonomic else "goal")
    times = []
    for heading in HEADINGS:
        start = RobotPose(0.0, 0.0, heading, z=0.22)  # body starts low: vz works too
        pose, arrival = run_to_goal(cfg, start, goal, holonomic)
        assert abs(pose.z - cfg.z_nominal) < 1e-3
        times.append(arrival)
    # Sanity bound on the time: straight-line distance at full speed plus turning and
    # the exponential slow-down near the goal.
    distance = math.hypot(goal.x, goal.y)
    assert max(times) < distance / cfg.max_vx + math.pi / cfg.max_yaw_rate + 8.0


@pytest.mark.parametrize("holonomic", [False, True], ids=["unicycle", "holonomic"])
def test_reaches_goal_with_rate_limits(holonomic):
    cfg = PlannerConfig(
        mode="holonomic" if holonomic else "goal", max_linear_accel=0.8, max_yaw_accel=2.0
    )
    for heading in HEADINGS[::2]:
        for goal in GOALS[:4]:
            run_to_goal(cfg, RobotPose(0.5, -0.5, heading, z=0.3), goal, holonomic)


def test_holonomic_mode_does_not_need_to_turn():
    cfg = PlannerConfig(mode="holonomic")
    planner = ReferencePlanner(cfg)
    planner.set_goal(0.0, 2.0)  # to the left of a robot facing +x
    cmd = planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3))
    assert cmd.vx == pytest.approx(0.0, abs=1e-12)
    assert cmd.vy == pytest.approx(cfg.max_vy)
    assert cmd.yaw_rate == 0.0
    # Diagonal goal: the direction is preserved when the command is saturated.
    planner.set_goal(3.0, 3.0)
    cmd = planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3))
    assert cmd.vx == pytest.approx(cmd.vy)
    assert max(abs(cmd.vx), abs(cmd.vy)) == pytest.approx(min(cfg.max_vx, cfg.max_vy))
    pose, _ = run_to_goal(cfg, RobotPose(0.0, 0.0, 0.0, 0.3), Goal(0.0, 2.0), holonomic=True)
    assert pose.yaw == pytest.approx(0.0, abs=1e-12)  # never turned


def test_unicycle_turns_in_place_when_goal_is_behind():
    cfg = PlannerConfig()
    planner = ReferencePlanner(cfg)
    planner.set_goal(-2.0, 0.1)
    cmd = planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3))
    assert cmd.vx == 0.0 and cmd.vy == 0.0
    assert cmd.yaw_rate == pytest.approx(cfg.max_yaw_rate)


@pytest.mark.parametrize("kind, walks", [("quadruped", False), ("biped", True)])
def test_robot_profiles_speed_law_at_a_steered_heading(kind, walks):
    """70 deg off the goal (where the whole body's steering holds the biped round a pillar):
    the default speed law stops and turns in place; the biped profile's walks on."""
    from safe_legged_c3bf.run.parameters import robot_profile

    planner_params = robot_profile(kind).get("reference_planner", {})
    planner = ReferencePlanner(PlannerConfig(**planner_params))
    heading = math.radians(70.0)
    planner.set_goal(3.0 * math.cos(heading), 3.0 * math.sin(heading))
    cmd = planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3))
    assert (cmd.vx > 0.0) is walks, cmd
    assert cmd.yaw_rate > 0.0


def test_slows_down_near_goal():
    cfg = PlannerConfig()
    planner = ReferencePlanner(cfg)
    planner.set_goal(10.0, 0.0)
    far = planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3)).vx
    near = planner.compute(RobotPose(9.8, 0.0, 0.0, 0.3)).vx
    assert far == pytest.approx(cfg.max_vx)
    assert near == pytest.approx(cfg.k_speed * 0.2)


def test_arrival_hysteresis():
    cfg = PlannerConfig(goal_tolerance=0.05, resume_distance=0.15)
    planner = ReferencePlanner(cfg)
    planner.set_goal(1.0, 0.0)
    planner.compute(RobotPose(0.97, 0.0, 0.0, 0.3))
    assert planner.arrived
    # Pushed to 0.1 m (between tolerance and resume distance): stays stopped.
    cmd = planner.compute(RobotPose(0.9, 0.0, 0.0, 0.3))
    assert planner.arrived and (cmd.vx, cmd.yaw_rate) == (0.0, 0.0)
    # Pushed beyond the resume distance: drives again.
    cmd = planner.compute(RobotPose(0.8, 0.0, 0.0, 0.3))
    assert planner.status is PlannerStatus.DRIVING and cmd.vx > 0.0


def test_yaw_alignment_and_hysteresis():
    cfg = PlannerConfig(yaw_tolerance=0.05, yaw_resume_tolerance=0.15)
    planner = ReferencePlanner(cfg)
    planner.set_goal(1.0, 0.0, yaw=1.0)
    cmd = planner.compute(RobotPose(1.0, 0.0, 0.0, 0.3))
    assert planner.status is PlannerStatus.ALIGNING
    assert cmd.vx == 0.0 and cmd.yaw_rate == pytest.approx(min(cfg.k_yaw, cfg.max_yaw_rate))
    planner.compute(RobotPose(1.0, 0.0, 0.97, 0.3))
    assert planner.arrived
    planner.compute(RobotPose(1.0, 0.0, 0.9, 0.3))
    assert planner.arrived
    planner.compute(RobotPose(1.0, 0.0, 0.8, 0.3))
    assert planner.status is PlannerStatus.ALIGNING


def test_constant_velocity_mode_outputs_constant_command():
    cfg = PlannerConfig(mode="constant_velocity", constant_velocity=(0.4, -0.1, 0.2))
    planner = ReferencePlanner(cfg)
    planner.set_goal(0.0, 0.0)  # ignored in this mode
    for pose in [
        RobotPose(0.0, 0.0, 0.0, cfg.z_nominal),
        RobotPose(-5.0, 3.0, 2.0, cfg.z_nominal),
        RobotPose(100.0, 0.0, -3.0, None),
    ]:
        assert planner.compute(pose).as_tuple() == (0.4, -0.1, 0.0, 0.2)
        assert planner.status is PlannerStatus.CONSTANT
    # The vertical channel still holds the body height.
    cmd = planner.compute(RobotPose(0.0, 0.0, 0.0, cfg.z_nominal - 0.05))
    assert cmd.vz == pytest.approx(cfg.k_z * 0.05)
    assert (cmd.vx, cmd.vy, cmd.yaw_rate) == (0.4, -0.1, 0.2)


def test_constant_velocity_mode_with_rate_limit_ramps_to_constant():
    cfg = PlannerConfig(
        mode="constant_velocity",
        constant_velocity=(0.5, 0.0, 0.5),
        max_linear_accel=1.0,
        max_yaw_accel=1.0,
    )
    planner = ReferencePlanner(cfg)
    prev = None
    for k in range(60):
        cmd = planner.compute(RobotPose(0.0, 0.0, 0.0, cfg.z_nominal), k * DT)
        check_limits(cfg, cmd, prev, holonomic=True)
        prev = cmd
    assert cmd.as_tuple() == pytest.approx((0.5, 0.0, 0.0, 0.5))


def test_height_hold_is_saturated():
    cfg = PlannerConfig(z_nominal=0.3, k_z=2.0, max_vz=0.2)
    planner = ReferencePlanner(cfg)
    assert planner.compute(RobotPose(0, 0, 0, 0.25)).vz == pytest.approx(0.1)
    assert planner.compute(RobotPose(0, 0, 0, 0.0)).vz == pytest.approx(0.2)
    assert planner.compute(RobotPose(0, 0, 0, 1.0)).vz == pytest.approx(-0.2)
    assert planner.compute(RobotPose(0, 0, 0, None)).vz == 0.0
    assert planner.status is PlannerStatus.IDLE
    off = ReferencePlanner(PlannerConfig(hold_height=False))
    assert off.compute(RobotPose(0, 0, 0, 0.0)).vz == 0.0


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        ((math.nan, 1.0), "x is not finite"),
        ((1.0, math.inf), "y is not finite"),
        ((1.0, 1.0, math.nan), "yaw is not finite"),
        (("1.0", 1.0), "x is not a number"),
        ((True, 1.0), "x is not a number"),
        ((1.0, 1.0, None, "map"), "frame 'map'"),
        ((1.0, 1.0, None, ""), "frame ''"),
    ],
)
def test_malformed_goals_are_ignored_with_reason(args, fragment):
    goal, reason = validate_goal(*args)
    assert goal is None and fragment in reason
    planner = ReferencePlanner()
    assert planner.set_goal(2.0, 0.0, frame_id="odom") == (True, "")
    ok, reason = planner.set_goal(*args)
    assert not ok and fragment in reason
    assert planner.goal == Goal(2.0, 0.0)  # previous goal kept
    assert fragment in planner.last_reason
    assert planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3)).vx > 0.0


def test_valid_goal_is_normalised():
    goal, reason = validate_goal(1, 2.5, 3 * math.pi, frame_id="odom")
    assert reason == "" and goal == Goal(1.0, 2.5, pytest.approx(-math.pi))
    assert validate_goal(1.0, 2.0) == (Goal(1.0, 2.0, None), "")


def test_invalid_pose_commands_stop():
    planner = ReferencePlanner()
    planner.set_goal(2.0, 0.0)
    cmd = planner.compute(RobotPose(math.nan, 0.0, 0.0, 0.3))
    assert cmd == VelocityCommand()
    assert planner.status is PlannerStatus.INVALID_POSE


def test_no_goal_means_idle():
    planner = ReferencePlanner()
    cmd = planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3))
    assert planner.status is PlannerStatus.IDLE and cmd == VelocityCommand()
    planner.set_goal(1.0, 0.0)
    planner.clear_goal()
    assert planner.compute(RobotPose(0.0, 0.0, 0.0, 0.3)) == VelocityCommand()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"max_vx": 0.0}, "max_vx"),
        ({"max_vy": -1.0}, "max_vy"),
        ({"max_yaw_rate": math.nan}, "max_yaw_rate"),
        ({"max_vz": math.inf}, "max_vz"),
        ({"max_vx_backward": -0.1}, "max_vx_backward"),
        ({"max_linear_accel": 0.0}, "max_linear_accel"),
        ({"max_yaw_accel": -2.0}, "max_yaw_accel"),
        ({"k_speed": 0.0}, "k_speed"),
        ({"k_speed": 3.0, "k_heading": 2.0}, "k_heading"),
        ({"k_speed": 1.5, "max_yaw_rate": 0.5}, "max_yaw_rate"),
        ({"goal_tolerance": 0.2, "resume_distance": 0.1}, "resume_distance"),
        ({"yaw_tolerance": 0.2, "yaw_resume_tolerance": 0.1}, "yaw_resume_tolerance"),
        ({"heading_slowdown_angle": 2.0}, "heading_slowdown_angle"),
        ({"z_nominal": math.nan}, "z_nominal"),
        ({"mode": "teleport"}, "mode"),
        ({"mode": "constant_velocity", "constant_velocity": (1.0, 0.0, 0.0)}, "constant_velocity"),
        ({"constant_velocity": (0.0, 0.0, 5.0)}, "constant_velocity"),
        ({"constant_velocity": (0.0, math.nan, 0.0)}, "constant_velocity"),
        ({"control_period": 0.0}, "control_period"),
        ({"hold_height": "yes"}, "hold_height"),
    ],
)
def test_invalid_config_names_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        PlannerConfig(**kwargs)


@settings(max_examples=200, deadline=None)
@given(
    mode=st.sampled_from(["goal", "holonomic"]),
    pose=st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-10, 10), st.floats(-1, 2)),
    goal=st.tuples(st.floats(-20, 20), st.floats(-20, 20)),
    yaw=st.one_of(st.none(), st.floats(-10, 10)),
)
def test_single_commands_respect_limits(mode, pose, goal, yaw):
    cfg = PlannerConfig(mode=mode)
    planner = ReferencePlanner(cfg)
    planner.set_goal(goal[0], goal[1], yaw)
    cmd = planner.compute(RobotPose(*pose))
    check_limits(cfg, cmd, holonomic=mode == "holonomic")


def test_rate_limiter_survives_clock_jump_back():
    cfg = PlannerConfig(
        mode="constant_velocity", constant_velocity=(0.5, 0.0, 0.0), max_linear_accel=1.0
    )
    planner = ReferencePlanner(cfg)
    for k in range(50):
        planner.compute(RobotPose(0.0, 0.0, 0.0, cfg.z_nominal), 100.0 + k * DT)
    planner.reset()
    # Simulation restarted: time goes back to 0; the limiter restarts instead of freezing.
    cmds = [planner.compute(RobotPose(0.0, 0.0, 0.0, cfg.z_nominal), k * DT).vx for k in range(40)]
    assert cmds[0] == pytest.approx(cfg.max_linear_accel * cfg.control_period)
    assert cmds[-1] == pytest.approx(0.5)


def test_orbit_conditions_only_apply_to_goal_mode():
    PlannerConfig(mode="holonomic", k_speed=3.0, k_heading=2.0)
    with pytest.raises(ValueError, match="k_heading"):
        PlannerConfig(mode="goal", k_speed=3.0, k_heading=2.0)
