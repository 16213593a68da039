"""Bars the whole body cannot duck under become walls in x-y (``safety.bar_walls``, #16)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from filter_harness import ScriptedObstacle, SimpleRobot, body_gap

from safe_legged_c3bf.c3bf.body import robot_body
from safe_legged_c3bf.c3bf.geometry import Plane
from safe_legged_c3bf.evaluation.results import read_csv
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.bar_walls import (
    WALL_BAND,
    WALL_BULGE,
    WALL_FORGET,
    WALL_SETTLE,
    BarWalls,
    bar_extents,
)
from safe_legged_c3bf.safety.obstacle_input import (
    ObstacleSet,
    to_c3bf_obstacles,
    to_c3bf_obstacles_walled,
)
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle

A1_MIN_HEIGHT = 0.18  # the A1 controller's lowest body height (the bar scenarios' window)
MARGIN = 0.05
QP_MARGIN = 0.01


def a1_walls() -> BarWalls:
    return BarWalls.for_body(robot_body("a1"), A1_MIN_HEIGHT, QP_MARGIN)


def bar_set(z: float, radius: float = 0.05, x: float = 2.5, y: float = 0.0,
            extent: float = 4.0) -> ObstacleSet:
    return ObstacleSet.from_arrays(["bar"], [1], [[x, y, z]], [[0, 0, 0]],
                                   [[radius, radius]], [extent])


def convert(obstacles: ObstacleSet, robot=(0.0, 0.0), yaw: float = 0.0,
            walls: BarWalls | None = None):
    walls = a1_walls() if walls is None else walls
    return to_c3bf_obstacles_walled(obstacles, 0.0, robot[1], 0.0, 0.0, MARGIN, 0.1, yaw,
                                    0.0, 0.17, walls, robot[0])


def lowest_clear_axis(walls: BarWalls, radius: float) -> float:
    """The lowest bar axis height [m] the body passes under at min_height (by the rule)."""
    top = walls.min_height + walls.xz_height + walls.xz_radius
    return float(top.max()) + radius + MARGIN + QP_MARGIN


def test_the_rule_is_the_body_at_its_lowest_height_against_the_grown_bar():
    walls = a1_walls()
    clear = lowest_clear_axis(walls, 0.05)
    # The A1's trunk circles reach 0.060 m above the base (its top edge 0.058 m plus at most
    # TOP_EXCESS): 0.18 + 0.060 + 0.05 + 0.05 + 0.01 = 0.350 m.
    assert clear == pytest.approx(0.350, abs=1e-3)
    for z, walled in ((0.25, True), (clear - 1e-3, True), (clear + 1e-3, False),
                      (0.60, False), (0.03, True)):  # 0.03: a kerb, below the legs' band
        _, _, mask = convert(bar_set(z))
        assert bool(mask.all() if mask.size else False) is walled, z


def test_a_walled_bar_is_its_footprint_with_its_ends_and_its_id():
    circles, ids, mask = convert(bar_set(0.25), robot=(0.0, 0.0))
    assert mask.all() and set(ids) == {"bar"}
    assert (np.asarray(circles.plane) == int(Plane.VERTICAL)).all()
    # Few circles (WALL_BULGE), covering the rectangle x 2.45..2.55, y -2..2, ends included.
    assert len(ids) <= 10
    assert (circles.radius <= 0.05 + WALL_BULGE + MARGIN + 1e-9).all()
    xs, ys = np.meshgrid(np.linspace(2.45, 2.55, 5), np.linspace(-2.0, 2.0, 201))
    pts = np.column_stack([xs.ravel(), ys.ravel()])
    d = np.linalg.norm(pts[:, None, :] - circles.center[None, :, :], axis=2)
    assert (d <= circles.radius[None, :] - MARGIN + 1e-9).any(axis=1).all()
    # No y gate for a wall: beside the bar's end it is still there (its end is a wall's end).
    _, ids_aside, mask_aside = convert(bar_set(0.25), robot=(0.0, 2.5))
    assert mask_aside.all() and ids_aside


def test_a_short_walled_bar_covers_its_corners():
    """A footprint too short for a row of circles still covers its rectangle's corners."""
    circles, ids, mask = convert(bar_set(0.25, extent=0.12))
    assert mask.all() and len(ids) == 1
    corners = np.array([[2.45, -0.06], [2.55, 0.06], [2.45, 0.06], [2.55, -0.06]])
    d = np.linalg.norm(corners - circles.center[0], axis=1)
    assert (d <= circles.radius[0] - MARGIN + 1e-9).all()


def test_a_passable_bar_stays_a_bar_and_keeps_its_y_gate():
    circles, ids, mask = convert(bar_set(0.45))
    assert ids == ["bar"] and not mask.any()
    assert np.asarray(circles.plane).tolist() == [int(Plane.HORIZONTAL)]
    _, ids_aside, _ = convert(bar_set(0.45), robot=(0.0, 2.5))
    assert ids_aside == []


def test_a_robot_already_under_the_bar_keeps_the_bar():
    """A bar lowered onto the robot stays an x-z bar: as a wall the robot would be inside."""
    _, _, mask = convert(bar_set(0.25), robot=(2.5, 0.0))
    assert not mask.any()
    _, _, mask = convert(bar_set(0.25), robot=(2.5 - 0.05 - 0.30 - 0.2, 0.0))  # cover 1 cm off
    assert mask.all()


def test_mixed_lists_keep_their_order_and_the_old_function_its_answer():
    obs = ObstacleSet.from_arrays(
        ["pillar", "low", "high"], [0, 1, 1],
        [[1.0, 1.0, 0.5], [2.5, 0.0, 0.25], [4.0, 0.0, 0.5]], np.zeros((3, 3)),
        [[0.1, 0.1], [0.05, 0.05], [0.05, 0.05]], [1.0, 4.0, 4.0],
    )
    circles, ids, mask = convert(obs)
    assert ids[0] == "pillar" and ids[-1] == "high" and set(ids[1:-1]) == {"low"}
    assert mask.tolist() == [i == "low" for i in ids]
    c2, ids2 = to_c3bf_obstacles(obs, 0.0, 0.0, 0.0, 0.0, MARGIN, 0.1, 0.0, 0.0, 0.17,
                                 a1_walls(), 0.0)
    assert ids2 == ids and np.array_equal(c2.center, circles.center)
    # Without walls (the single-point filter) every bar stays a bar.
    _, ids3 = to_c3bf_obstacles(obs, 0.0, 0.0, 0.0, 0.0, MARGIN, 0.1)
    assert ids3 == ["pillar", "low", "high"]


def test_a_tracked_bar_near_the_rule_does_not_flicker():
    """Noise of a few mm on a bar 2 mm passable by the rule: no switching (random A1 seed 46)."""
    walls, rng = a1_walls(), np.random.default_rng(0)
    states = [bool(walls.decide(["bar"], np.array([-0.002 + rng.normal(0, 0.008)]), 0.02 * k)[0])
              for k in range(3000)]
    assert sum(a != b for a, b in zip(states, states[1:], strict=False)) == 0
    assert not states[0]
    # The same noise 3 cm below the rule: a wall within the settling time, and it stays.
    states = [bool(walls.decide(["low"], np.array([0.03 + rng.normal(0, 0.008)]), 0.02 * k)[0])
              for k in range(3000)]
    settle = round(WALL_SETTLE / 0.02)
    assert all(states[settle:])
    assert sum(a != b for a, b in zip(states, states[1:], strict=False)) <= 1
    # Untracked (no id) or no time: the rule at this instant.
    assert walls.decide([""], np.array([0.001]), 1.0).tolist() == [True]
    assert walls.decide(["bar"], np.array([0.001]), None).tolist() == [True]


def test_one_noisy_first_sighting_does_not_wall_a_passable_bar_for_good():
    """A track's first height is the raw detection's (2 cm noise): it is averaged first (b007)."""
    walls = a1_walls()
    # A bar 6 mm passable, first seen 2 sigma low (decided alone: a wall, beyond the band
    # the hysteresis would keep), then the tracker's filtered estimate.
    assert walls.decide(["bar"], np.array([0.034]), 0.0)[0]
    rng = np.random.default_rng(1)
    states = [bool(walls.decide(["bar"], np.array([-0.006 + rng.normal(0, 0.004)]),
                                0.05 * k)[0]) for k in range(1, 400)]
    settle = round(WALL_SETTLE / 0.05)
    assert not any(states[settle:])  # a bar from the end of the settling on


def test_a_clearly_low_bar_is_a_wall_while_it_settles():
    walls = a1_walls()
    states = [bool(walls.decide(["low"], np.array([0.06]), 0.05 * k)[0]) for k in range(40)]
    assert all(states)
    states = [bool(walls.decide(["low2"], np.array([0.02]), 0.05 * k)[0]) for k in range(40)]
    settle = round(WALL_SETTLE / 0.05)
    assert not any(states[:settle]) and all(states[settle:])


def test_a_bar_that_rises_stops_being_a_wall_and_a_forgotten_one_starts_afresh():
    walls = a1_walls()
    assert walls.decide(["b"], np.array([0.05]), 0.0)[0]
    t, walled = 0.0, True
    while walled:  # rises 5 cm/s: deficit falls through the band
        t += 0.02
        walled = bool(walls.decide(["b"], np.array([0.05 - 0.05 * t]), t)[0])
    assert 1.0 + WALL_BAND / 0.05 < t < 1.0 + WALL_BAND / 0.05 + 1.5  # the average lags ~1 s
    later = t + WALL_FORGET + 0.1
    walls.decide(["other"], np.array([0.0]), later)  # "b" unseen for longer than WALL_FORGET
    assert "b" not in walls._memory


def test_with_a_judge_range_a_far_bar_is_judged_only_once_the_robot_is_near():
    """Sensors: a bar's height measured from afar errs low; it is judged within range only."""
    ranged = BarWalls.for_body(robot_body("a1"), A1_MIN_HEIGHT, QP_MARGIN, judge_range=1.0)
    low = bar_set(0.25, x=2.5)  # too low by the rule; footprint x 2.45 .. 2.55
    for x, walled in ((0.0, False), (1.40, False), (1.50, True), (2.0, True)):
        walls = BarWalls.for_body(robot_body("a1"), A1_MIN_HEIGHT, QP_MARGIN, judge_range=1.0)
        _, _, mask = convert(low, robot=(x, 0.0), walls=walls)
        assert bool(mask.any()) is walled, x
        _, _, mask = convert(low, robot=(x, 0.0))  # no range: walled from anywhere
        assert mask.all(), x
    # Tracked: far sightings are not remembered, the settling starts within range.
    centre, half = np.array([[2.5, 0.0]]), (np.array([0.05]), np.array([2.0]))
    assert ranged.out_of_range(np.array([0.0, 0.0]), centre, *half).tolist() == [True]
    assert ranged.out_of_range(np.array([1.6, 0.0]), centre, *half).tolist() == [False]
    assert ranged.out_of_range(np.array([2.5, 3.5]), centre, *half).tolist() == [True]


def test_extents_of_a_tilted_ellipse():
    x_half, z_half = bar_extents(np.array([[0.3, 0.1]]), np.array([math.pi / 2]))
    assert x_half[0] == pytest.approx(0.1) and z_half[0] == pytest.approx(0.3)
    x_half, _ = bar_extents(np.array([[0.3, 0.1]]), np.array([math.pi / 4]))
    assert x_half[0] == pytest.approx(math.sqrt((0.09 + 0.01) / 2))


def test_the_point_filter_has_no_walls():
    assert BarWalls.for_body(None, 0.18) is None
    cycle = SafetyFilterCycle(FilterParams(body_model="point"))
    assert cycle.shaping.walls is None


RATE = 50.0
DT = 1.0 / RATE


def hold_before(z: float, model: str, start_z: float, noise: float, seconds: float = 30.0):
    """Closed loop before a bar with a planner that keeps asking to go on at standing height.

    ``noise`` [m/s]: white noise on the measured velocities (a walking robot's odometry).
    Returns the robot's x over time and the least gap to the bar.
    """
    params = FilterParams(body_model="body", model=model, min_height=A1_MIN_HEIGHT,
                          max_height=0.285)
    cycle = SafetyFilterCycle(params)
    bar = ScriptedObstacle("bar", np.array([2.5, 0.0, z]), semi_axes=(0.05, 0.05), plane=1,
                           extent=4.0)
    robot, rng = SimpleRobot(z=start_z), np.random.default_rng(3)
    xs, gaps = [], []
    for k in range(int(seconds * RATE)):
        t = k * DT
        ref = VelocityCommand(0.4, 0.0, 2.0 * (0.28 - robot.z), 0.0)
        base = robot.base_state(t)
        base = type(base)(base.position, base.orientation,
                          tuple(np.asarray(base.linear_velocity) + rng.normal(0, noise, 3)),
                          base.angular_velocity, base.stamp)
        out = cycle.step(t, ref, t, base, [bar.at(t)], t)
        xs.append(robot.x)
        gaps.append(body_gap(robot, bar, t, params))
        for _ in range(10):
            robot.step(out.command, DT / 10)
    return np.array(xs), min(gaps)


@pytest.mark.parametrize("model", ["unicycle_lateral", "unicycle", "holonomic"])
@pytest.mark.parametrize("start_z", [0.28, 0.32])
def test_the_robot_holds_its_stop_before_an_impassable_bar(model, start_z):
    xs, gap = hold_before(0.25, model, start_z, noise=0.03)
    assert gap > 0.0
    # Stopped where the bar came into view: the barrier never lets the cover approach a wall
    # head-on, and the hold keeps the QP from sliding along it (without the wall the robot
    # ducks up to 1.8 m; without the hold the side-stepping model walks round the bar's end).
    assert xs.max() < 0.3
    last = xs[-int(5 * RATE):]
    assert last.max() - last[0] <= 0.01, "crept towards the bar"


def test_a_reference_that_backs_off_or_turns_away_is_followed():
    """The hold stops only a path into the wall: backing off and turning are followed."""
    params = FilterParams(body_model="body", model="unicycle_lateral",
                          min_height=A1_MIN_HEIGHT, max_height=0.285)
    bar = ScriptedObstacle("bar", np.array([1.5, 0.0, 0.25]), semi_axes=(0.05, 0.05), plane=1,
                           extent=4.0)
    for ref, check in ((VelocityCommand(-0.2), lambda r: r.x < -0.5),
                       (VelocityCommand(0.0, 0.0, 0.0, 0.5), lambda r: abs(r.yaw) > 1.0)):
        cycle, robot = SafetyFilterCycle(params), SimpleRobot()
        for k in range(int(5 * RATE)):
            t = k * DT
            out = cycle.step(t, ref, t, robot.base_state(t), [bar.at(t)], t)
            assert "holding" not in out.text
            for _ in range(10):
                robot.step(out.command, DT / 10)
        assert check(robot), (ref, robot)


def test_blocks_is_the_cover_against_the_wall_circles():
    walls = a1_walls()
    centres, still, radii = np.array([[1.0, 0.0]]), np.zeros((1, 2)), np.array([0.1])
    pos = np.zeros(3)
    fwd = np.array([0.4, 0.0])
    assert walls.blocks(pos, 0.0, fwd, centres, still, radii)
    assert walls.blocks(pos, 0.0, fwd, centres + [[40.0, 0.0]], still, radii)  # any distance
    assert not walls.blocks(pos, 0.0, np.array([-0.2, 0.0]), centres, still, radii)
    assert not walls.blocks(pos, 0.0, np.array([0.0, 0.0]), centres, still, radii)
    assert not walls.blocks(pos, 0.0, fwd, centres, still, radii, 1.0)  # a horizon, if given
    assert not walls.blocks(pos, 0.0, fwd, centres, np.array([[0.5, 0.0]]), radii)  # receding
    # Sideways at yaw pi/2: base_link +x is odom +y; the circle at (1, 0) is beside the path.
    assert not walls.blocks(pos, math.pi / 2, fwd, centres, still, radii)
    # The A1's footprint circles (radius 0.2007 m on its axis) pass a circle of radius 0.1
    # at y = 0.32 with 2 cm to spare; one at y = 0.28 they touch.
    assert not walls.blocks(pos, 0.0, fwd, np.array([[1.0, 0.32]]), still, radii)
    assert walls.blocks(pos, 0.0, fwd, np.array([[1.0, 0.28]]), still, radii)


@pytest.mark.slow
def test_the_a1_holds_its_stop_before_the_named_low_bar(tmp_path):
    """quadruped_low_bar in PyBullet: stopped before the bar, untouched, no creep (#16).

    With the bar kept in x-z the A1 ducked and rose in front of it, crept 5 cm in the last
    5 s and had touched it in earlier versions.
    """
    out = tmp_path / "low_bar"
    proc = subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.evaluate", "--scenario", "quadruped_low_bar",
         "--in-process", "--no-baseline", "--no-free", "--no-figures", "--out", str(out)],
        cwd=Path(__file__).resolve().parents[1], capture_output=True, text=True, timeout=600,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (row,) = read_csv(out / "results.csv")
    detail = json.dumps(row, default=str)
    assert row["outcome"] == "stopped_impassable", detail
    assert row["collision"] is False and row["stopped_before_impassable"] is True, detail
    assert row["creep"] <= 0.01, detail
