"""Leaving a standstill in a pocket of walls: the cone steering's detour (issue #17)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filter_harness import SimpleRobot

from safe_legged_c3bf.c3bf.body import robot_body
from safe_legged_c3bf.c3bf.geometry import Plane
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety import stall_detour
from safe_legged_c3bf.safety.obstacle_input import ObstacleInput
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle
from safe_legged_c3bf.safety.stall_detour import StallDetour

RATE = 50.0
DT = 1.0 / RATE
GOAL = np.array([7.0, 0.0])
#: (centre x, y, half length, half thickness, orientation): a pocket open towards -x.
WALLS = [(3.6, 0.0, 1.3, 0.1, math.pi / 2), (2.3, 1.2, 1.3, 0.1, 0.0),
         (2.3, -1.2, 1.3, 0.1, 0.0)]


def walls() -> list[ObstacleInput]:
    return [ObstacleInput(f"wall{i}", 0, np.array([x, y, 0.6]), np.zeros(3),
                          np.array([a, b]), 1.2, th) for i, (x, y, a, b, th) in enumerate(WALLS)]


def gap(robot: SimpleRobot) -> float:
    """Least distance [m] from the A1's x-y cover to a wall's box (negative: overlap)."""
    c, s = math.cos(robot.yaw), math.sin(robot.yaw)
    out = math.inf
    for p in robot_body("a1").points_in(Plane.VERTICAL):
        px = robot.x + c * p.offset[0] - s * p.offset[1]
        py = robot.y + s * p.offset[0] + c * p.offset[1]
        for x, y, a, b, th in WALLS:
            u = (px - x) * math.cos(th) + (py - y) * math.sin(th)
            v = -(px - x) * math.sin(th) + (py - y) * math.cos(th)
            d = math.hypot(max(abs(u) - a, 0.0), max(abs(v) - b, 0.0))
            out = min(out, d - p.radius)
    return out


def goal_seeking(robot: SimpleRobot) -> VelocityCommand:
    """The planner: obstacle-agnostic, slows to 0 at 60 deg heading error (as ours)."""
    d = GOAL - (robot.x, robot.y)
    error = math.remainder(math.atan2(d[1], d[0]) - robot.yaw, math.tau)
    vx = 0.4 * max(0.0, 1.0 - abs(error) / (math.pi / 3)) if np.hypot(*d) > 0.3 else 0.0
    return VelocityCommand(vx, 0.0, 0.0, max(-1.0, min(1.0, 1.5 * error)))


def run(seconds: float = 60.0):
    cycle = SafetyFilterCycle(FilterParams(body_model="body", model="unicycle_lateral"))
    robot = SimpleRobot(x=2.3, y=0.0)  # inside the pocket, facing its back wall
    obstacles, gaps, texts = walls(), [], set()
    for k in range(int(seconds * RATE)):
        t = k * DT
        out = cycle.step(t, goal_seeking(robot), t, robot.base_state(t), obstacles, t)
        texts.add(out.text.split(" (")[-1])
        for _ in range(5):
            robot.step(out.command, DT / 5)
        gaps.append(gap(robot))
        if np.hypot(*(GOAL - (robot.x, robot.y))) < 0.3:
            break
    return robot, min(gaps), t


def test_a_robot_in_a_pocket_leaves_it_and_reaches_the_goal():
    robot, least, t = run()
    assert np.hypot(*(GOAL - (robot.x, robot.y))) < 0.3, (robot, t)
    assert least > 0.0


def test_without_the_detour_it_stands_in_the_pocket(monkeypatch):
    monkeypatch.setattr(stall_detour, "STALL_TIME", math.inf)
    robot, least, _ = run(30.0)
    assert np.hypot(*(GOAL - (robot.x, robot.y))) > 3.0 and least > 0.0


def _blocked_within(half_width: float):
    return lambda psi: np.abs(np.remainder(np.asarray(psi) + math.pi, math.tau) - math.pi) < (
        half_width)


def _grid_heading(edge: float, step: float = math.radians(5.0)) -> float:
    """The heading a detour aims at: the first free 5-degree step past ``edge``, 2 more."""
    return (math.ceil(edge / step) + 2) * step


def test_a_detour_follows_the_free_heading_nearest_the_goal_and_ends_when_that_is_free():
    d = StallDetour(math.radians(5.0), 1.5, 0.1, 2)
    ahead = _blocked_within(1.0)  # every heading within 1 rad of odom +x
    assert not d.stalled(0.0, 0.0) and not d.stalled(1.9, 0.0) and d.stalled(2.0, 0.0)
    assert d.start(2.0, 0.0, 1, ahead) and d.active
    vx, wz, side = d.step(2.0, 0.0, 0.0, 0.3, 0.3, 0.0, 1.0, ahead)
    assert side == 1 and vx == 0.0 and wz == pytest.approx(1.0)  # turn in place first
    heading = _grid_heading(1.0)
    vx, wz, _ = d.step(3.0, heading, 0.0, 0.3, 0.0, -1.0, 1.0, ahead)
    assert vx > 0.25 and abs(wz) < 0.1  # walks the free heading, whatever the planner asks
    assert d.step(4.0, heading, 0.3, 0.3, 0.0, 0.0, 1.0, ahead) is None  # the planner stopped
    assert not d.active
    d.start(5.0, 0.0, -1, ahead)
    assert d.step(6.0, 0.0, 0.3, 0.3, 0.3, 0.0, 1.0, _blocked_within(0.0)) is None  # free
    assert not d.stalled(7.0, 0.2)  # moving: the standstill clock restarts


def test_a_free_heading_behind_is_backed_along_and_a_detour_has_an_end():
    d = StallDetour(math.radians(5.0), 1.5, 0.1, 2)
    boxed = _blocked_within(2.5)  # free only within 0.64 rad of straight behind
    assert d.start(0.0, 0.0, 1, boxed)
    vx, wz, side = d.step(0.0, 0.0, 0.0, 0.3, 0.3, 0.0, 1.0, boxed)
    heading = _grid_heading(2.5)
    assert vx < 0.0 and side == 1  # backs out, rear first
    assert wz == pytest.approx(1.5 * math.remainder(heading - math.pi, math.tau))
    assert d.step(stall_detour.DETOUR_MAX + 0.1, 0.0, 0.0, 0.3, 0.3, 0.0, 1.0, boxed) is None
    assert not d.start(0.0, 0.0, 1, _blocked_within(4.0))  # nothing free at all


def _half_ring(speed: float):
    angles = np.radians(np.arange(-130.0, 131.0, 10.0))
    centres = [[1.0 * math.cos(a), 1.0 * math.sin(a)] for a in angles]
    return centres, [[0.0, speed]] * len(centres), [0.3] * len(centres)


@pytest.mark.parametrize(("speed", "detour"), [(0.0, True), (0.3, False)])
def test_a_standstill_among_static_obstacles_detours_one_among_movers_waits(speed, detour):
    from safe_legged_c3bf.safety.cone_steering import ConeSteering

    s = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0)
    outs = [s.steer(0.1 * k, (0, 0), 0.0, 0.4, 0.0, *_half_ring(speed), 1.0, speed=0.0)
            for k in range(31)]
    assert not any(o.detour for o in outs[:20])  # 2 s standing first
    assert outs[-1].detour is detour
    if detour:
        assert outs[-1].vx < 0.0  # the free headings are behind: it backs out
    else:
        assert not outs[-1].free  # held by movers: the QP brakes, the robot waits


@pytest.mark.parametrize(("pillar_speed", "robot_speed", "detour"),
                         [(0.0, 0.0, True), (0.3, 0.0, False), (0.0, 0.2, False)])
def test_a_standoff_detours_after_its_time_unless_walking_or_held_by_a_mover(
        pillar_speed, robot_speed, detour):
    """The planner creeps (2 cm/s, its momentary speed makes every heading look free) at a
    pillar 1 m ahead while the robot stands and its yaw swings to and fro (+-0.3 rad, 2 s): a
    detour after ``STANDOFF_TIME``; none while the robot walks, none for a mover, none for a
    robot that only turns one way (a long turn towards a free heading)."""
    from safe_legged_c3bf.safety.cone_steering import ConeSteering

    pillar = ([[1.0, 0.0]], [[0.0, pillar_speed]], [0.3])

    def first_detour(yaw):  # noqa: ANN001, ANN202
        s = ConeSteering(20.0, 0.2, 0.5, 1.5, cruise_memory=30.0)
        s.steer(0.0, (0, 0), 0.0, 0.4, 0.0, *pillar, 1.0, speed=robot_speed)  # cruise 0.4
        outs = [s.steer(0.1 * k, (0, 0), yaw(0.1 * k), 0.02, 0.0, *pillar, 1.0,
                        speed=robot_speed) for k in range(1, 101)]
        return next((0.1 * k for k, o in enumerate(outs, 1) if o.detour), None), outs[-1]

    start, last = first_detour(lambda t: 0.3 * math.sin(math.pi * t))
    if detour:
        assert start is not None and start >= stall_detour.STANDOFF_TIME
        assert last.side != 0 and last.detour
    else:
        assert start is None
    assert first_detour(lambda t: 0.1 * t)[0] is None  # one way only: no standoff


def _biped_standoff(standoff_time: float, monkeypatch) -> float:
    """Random biped seed 4 at t = 18 s, in the unit harness (biped profile, first-order robot):
    stood between two pillars and two stopped walkers, its goal 2.6 m away behind them.
    Returns the time [s] the goal is reached (inf: not in 40 s)."""
    from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand as Command
    from safe_legged_c3bf.planning.reference_planner import (
        PlannerConfig,
        ReferencePlanner,
        RobotPose,
    )
    from safe_legged_c3bf.run.parameters import robot_profile

    monkeypatch.setattr(stall_detour, "STANDOFF_TIME", standoff_time)
    cycle = SafetyFilterCycle(FilterParams(**robot_profile("biped")["safety_filter"]))
    obstacles = [ObstacleInput(name, 0, np.array([x, y, 0.8]), np.zeros(3), np.array([a, b]),
                               1.6, 0.0)
                 for name, x, y, a, b in [("pillar_0", -0.86, -0.882, 0.227, 0.205),
                                          ("pillar_1", -1.423, -1.973, 0.232, 0.197),
                                          ("walker_2", -0.439, -2.442, 0.216, 0.192),
                                          ("walker_3", -1.206, -1.01, 0.153, 0.118)]]
    planner = ReferencePlanner(PlannerConfig(mode="goal", max_vx=0.2, z_nominal=0.82))
    goal = np.array([-2.193, -2.84])
    planner.set_goal(*goal)
    robot = SimpleRobot(x=-0.25, y=-1.6, yaw=math.radians(-118.0), z=0.81, tau=0.3,
                        holonomic=True)
    for k in range(int(40.0 * RATE)):
        t = k * DT
        ref = planner.compute(RobotPose(robot.x, robot.y, robot.yaw, robot.z), t)
        out = cycle.step(t, Command(ref.vx, ref.vy, 0.0, ref.yaw_rate), t,
                         robot.base_state(t), obstacles, t)
        for _ in range(5):
            robot.step(out.command, DT / 5)
        if np.hypot(*(goal - (robot.x, robot.y))) < 0.3:
            return t
    return math.inf


def test_a_standoff_between_pillars_and_stopped_walkers_is_left_sooner(monkeypatch):
    """Turning to and fro (the steering left, the planner back right) ends in a detour."""
    with_detour = _biped_standoff(stall_detour.STANDOFF_TIME, monkeypatch)
    without = _biped_standoff(math.inf, monkeypatch)
    assert with_detour < without - 5.0, (with_detour, without)
