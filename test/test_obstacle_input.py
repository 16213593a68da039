"""Obstacle lists validated once (ObstacleSet) and their vectorised conversion to circles."""

import math

import numpy as np
import pytest
from filter_harness import SimpleRobot

from safe_legged_c3bf.c3bf import InvalidInputError, Obstacles, Plane
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.elongated import MAX_BULGE, MAX_CIRCLES
from safe_legged_c3bf.safety.obstacle_input import (
    ObstacleInput,
    ObstacleSet,
    to_c3bf_obstacles,
)
from safe_legged_c3bf.safety.safety_cycle import CycleStatus, SafetyFilterCycle


def _cover(ob):
    """The circles of one obstacle, written out: ``[(offset (2,), radius)]`` in its plane."""
    a, b = (float(x) for x in ob.semi_axes)
    major, minor = max(a, b), min(a, b)
    if major <= 1.5 * minor:
        return [(np.zeros(2), major)]
    half_cell = math.sqrt((minor + MAX_BULGE) ** 2 - minor * minor)  # bulge <= MAX_BULGE
    k = min(math.ceil(major / half_cell), MAX_CIRCLES)
    axis = ob.orientation + (0.0 if a >= b else 0.5 * math.pi)
    u = np.array([math.cos(axis), math.sin(axis)])
    out = []
    for j in range(k):
        ends = np.array([-major + 2 * j * major / k, -major + 2 * (j + 1) * major / k])
        mid = ends.mean()
        # farthest point of the ellipse within the cell: on its boundary at one of the ends
        far = np.hypot(ends - mid, minor * np.sqrt(np.clip(1 - (ends / major) ** 2, 0, 1)))
        out.append((mid * u, float(far.max())))
    return out


def reference_circles(obstacles, dt, robot_y, width, height, margin, y_margin, yaw, tie_break,
                      tie_speed=0.0):
    """The per-obstacle loop the vectorised conversion replaced (kept as the reference)."""
    centers, velocities, radii, planes, ids = [], [], [], [], []
    for ob in obstacles:
        c = np.asarray(ob.center, dtype=float) + dt * np.asarray(ob.velocity, dtype=float)
        v = np.asarray(ob.velocity, dtype=float)
        speed = math.hypot(v[0], v[1])
        tie = tie_break if tie_speed == 0.0 else tie_break * min(speed / tie_speed, 1.0)
        for off, a in _cover(ob):
            if ob.plane == int(Plane.VERTICAL):
                right = (math.sin(yaw), -math.cos(yaw))
                centers.append((c[0] + off[0] + tie * right[0], c[1] + tie * right[1] + off[1]))
                velocities.append((v[0], v[1]))
                radii.append(a + 0.5 * width + margin + tie)
                planes.append(int(Plane.VERTICAL))
            else:
                half_span = 0.5 * ob.extent + 0.5 * width + y_margin
                if abs(robot_y - c[1]) > half_span:
                    continue
                centers.append((c[0] + off[0], c[2] + off[1]))
                velocities.append((v[0], v[2]))
                radii.append(a + 0.5 * height + margin)
                planes.append(int(Plane.HORIZONTAL))
            ids.append(ob.id)
    if not centers:
        return Obstacles.empty(), []
    return Obstacles(np.array(centers), np.array(velocities), np.array(radii),
                     np.array(planes)), ids


def random_inputs(rng, n, planes=(0, 1)):
    return [
        ObstacleInput(
            f"o{i}", int(rng.choice(planes)), rng.uniform(-5, 5, 3), rng.uniform(-1, 1, 3),
            rng.uniform(0.05, 0.6, 2), float(rng.uniform(0.2, 4.0)),
            float(rng.uniform(-np.pi, np.pi)),
        )
        for i in range(n)
    ]


def test_vectorised_conversion_matches_the_per_obstacle_loop():
    rng = np.random.default_rng(3)
    for trial in range(300):
        # mixed, only pillars (a faster path) and only bars
        obs = random_inputs(rng, int(rng.integers(0, 12)), [(0, 1), (0,), (1,)][trial % 3])
        args = (float(rng.uniform(0, 0.3)), float(rng.uniform(-3, 3)), 0.82, 0.12, 0.05, 0.1,
                float(rng.uniform(-np.pi, np.pi)), float(rng.choice([0.0, 0.03])))
        tie_speed = float(rng.choice([0.0, 0.1, 2.0]))  # 2 m/s: above every speed drawn
        expected, ids_e = reference_circles(obs, *args, tie_speed)
        for given in (obs, ObstacleSet.from_inputs(obs)):
            got, ids = to_c3bf_obstacles(given, *args, tie_break_speed=tie_speed)
            assert ids == ids_e, trial
            assert got.planes_present == expected.planes_present
            for name in ("center", "velocity", "radius", "plane"):
                np.testing.assert_allclose(getattr(got, name), getattr(expected, name),
                                           rtol=0, atol=1e-15, err_msg=name)
                assert not getattr(got, name).flags.writeable


def test_tie_break_in_proportion_to_speed_spares_static_obstacles():
    """With a full speed, a static obstacle is neither moved nor grown; a mover is, in full."""
    still = ObstacleInput("still", 0, np.array([2.0, 0.3, 0.5]), np.zeros(3), np.full(2, 0.2), 1.0)
    slow = ObstacleInput("slow", 0, np.array([2.0, -0.3, 0.5]), np.array([0.03, -0.04, 0.0]),
                         np.full(2, 0.2), 1.0)
    walker = ObstacleInput("walker", 0, np.array([4.0, 0.0, 0.5]), np.array([0.0, 0.4, 0.0]),
                           np.full(2, 0.2), 1.0)
    obs = ObstacleSet.from_inputs([still, slow, walker])
    np.testing.assert_allclose(obs.tie_breaks(0.03, 0.1), [0.0, 0.015, 0.03])
    np.testing.assert_allclose(obs.tie_breaks(0.03), [0.03] * 3)  # 0: every one in full
    wall = ObstacleInput("wall", 0, np.array([3.0, 1.0, 0.5]), np.zeros(3), np.array([1.5, 0.1]),
                         1.0)
    for given in ([still, slow, walker], [still, slow, walker, wall]):  # both conversion paths
        circles, ids = to_c3bf_obstacles(given, 0.0, 0.0, 0.0, 0.0, 0.05, 0.1, 0.0, 0.03,
                                         tie_break_speed=0.1)
        assert ids[:3] == ["still", "slow", "walker"]
        np.testing.assert_allclose(circles.center[:3], [[2.0, 0.3], [2.0, -0.315], [4.0, -0.03]])
        np.testing.assert_allclose(circles.radius[:3], [0.25, 0.265, 0.28])
        if len(given) == 4:  # the wall's row of circles: not moved, not grown
            full, _ = to_c3bf_obstacles([wall], 0.0, 0.0, 0.0, 0.0, 0.05, 0.1, 0.0, 0.0)
            np.testing.assert_allclose(circles.center[3:], full.center)
            np.testing.assert_allclose(circles.radius[3:], full.radius)


def test_obstacle_set_is_validated_once_and_read_only():
    ok = ObstacleInput("a", 0, np.array([2.0, 0.0, 0.5]), np.zeros(3), np.array([0.2, 0.3]), 1.0)
    s = ObstacleSet.from_inputs([ok, ok])
    assert len(s) == 2 and s.ids == ("a", "a")
    np.testing.assert_array_equal(s.size, [0.3, 0.3])
    for arr in (s.plane, s.center, s.velocity, s.size, s.extent):
        assert not arr.flags.writeable
    assert len(ObstacleSet.from_inputs([])) == 0
    bad = [
        ObstacleInput("n", 0, np.array([np.nan, 0.0, 0.5]), np.zeros(3), np.ones(2), 1.0),
        ObstacleInput("v", 0, np.zeros(3), np.array([0.0, np.inf, 0.0]), np.ones(2), 1.0),
        ObstacleInput("z", 0, np.zeros(3), np.zeros(3), np.array([0.2, 0.0]), 1.0),
        ObstacleInput("p", 2, np.zeros(3), np.zeros(3), np.ones(2), 1.0),
        ObstacleInput("e", 1, np.zeros(3), np.zeros(3), np.ones(2), math.nan),
    ]
    for b in bad:
        assert not b.is_valid()
        with pytest.raises(InvalidInputError):
            ObstacleSet.from_inputs([ok, b])
        with pytest.raises(InvalidInputError):
            to_c3bf_obstacles([ok, b], 0.0, 0.0, 0.8, 0.1, 0.0, 0.0)
    with pytest.raises(InvalidInputError):  # shapes that do not match the ids
        ObstacleSet.from_arrays(["a"], [0], [[1.0, 2.0]], [[0, 0, 0]], [[1, 1]], [1.0])


@pytest.mark.filterwarnings("ignore:overflow encountered")
def test_overflowing_prediction_is_rejected():
    fast = [ObstacleInput("fast", 0, np.zeros(3), np.array([1e308, 0.0, 0.0]), np.ones(2), 1.0)]
    with pytest.raises(InvalidInputError, match="domain"):  # refused before it can overflow
        ObstacleSet.from_inputs(fast)
    with pytest.raises(InvalidInputError):  # a list is validated the same way
        to_c3bf_obstacles(fast, 10.0, 0.0, 0.8, 0.1, 0.0, 0.0)
    edge = [ObstacleInput("edge", 0, np.zeros(3), np.array([1e9, 0.0, 0.0]), np.ones(2), 1.0)]
    ObstacleSet.from_inputs(edge)  # the domain's edge is accepted


def test_cycle_takes_a_set_or_a_list_and_brakes_on_invalid_obstacles():
    robot = SimpleRobot(vx=0.5)
    obs = [ObstacleInput("p", 0, np.array([2.0, 0.1, 0.5]), np.array([-0.2, 0.0, 0.0]),
                         np.array([0.25, 0.25]), 1.0)]
    with_list, with_set = SafetyFilterCycle(), SafetyFilterCycle()
    obs_set = ObstacleSet.from_inputs(obs)
    for k in range(50):
        t = 0.02 * k
        a = with_list.step(t, VelocityCommand(0.6), t, robot.base_state(t), obs, t - 0.01)
        b = with_set.step(t, VelocityCommand(0.6), t, robot.base_state(t), obs_set, t - 0.01)
        assert a.status is b.status and a.command == b.command and a.obstacle_ids == ["p"]
        robot.step(a.command, 0.02)
    assert a.status is CycleStatus.ACTIVE
    # An invalid obstacle in a list: the cycle brakes and says why (no exception).
    bad = [ObstacleInput("n", 0, np.array([np.nan, 0.0, 0.5]), np.zeros(3), np.ones(2), 1.0)]
    v0 = with_list.commanded.vx
    out = with_list.step(1.0, VelocityCommand(0.6), 1.0, robot.base_state(1.0), bad, 1.0)
    assert out.status is CycleStatus.INVALID_INPUT and "obstacle" in out.text
    assert 0.0 <= out.command.vx < v0
