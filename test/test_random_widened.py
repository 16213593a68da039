"""The widened random generator (issue #16): what it must now produce, over 60 seeds.

These check the distribution, never what the robot passes: impassable bars, walkers that
stop on or next to the path, walks that cross the start, up to 6 obstacles of which up to
4 move, walls and benches.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from safe_legged_c3bf.evaluation import random_scenario as rs
from safe_legged_c3bf.evaluation.impassable import impassable_obstacles
from safe_legged_c3bf.sim.scenario import parse_scenario

SEEDS = range(60)


def scenarios(robot):
    return [rs.random_scenario(robot, seed) for seed in SEEDS]


@pytest.fixture(scope="module", params=rs.ROBOTS)
def drawn(request):
    return request.param, scenarios(request.param)


def test_valid_and_reproducible(drawn):
    robot, scs = drawn
    for seed in (0, 17, 59):
        data = rs.generate_scenario(robot, seed)
        assert data == rs.generate_scenario(robot, seed)
        parse_scenario(data, name=data["name"], check_clearance=True)


def test_up_to_six_obstacles_of_which_up_to_four_move(drawn):
    _, scs = drawn
    counts = Counter(len(sc.obstacles) for sc in scs)
    movers = Counter(sum(rs.moving(o) for o in sc.obstacles) for sc in scs)
    assert max(counts) == 6 and min(counts) >= 1
    assert max(movers) == 4
    assert counts[5] + counts[6] >= 5 and movers[3] + movers[4] >= 5


def test_bars_at_every_height_including_impassable(drawn):
    _, scs = drawn
    undersides = [o.position[2] - max(o.semi_axes) for sc in scs for o in sc.obstacles
                  if o.plane == "horizontal"]
    assert len(undersides) >= 5
    impassable = sum(1 for sc in scs if any(b.kind == "bar" for b in impassable_obstacles(sc)))
    assert impassable >= 2
    passable = sum(1 for sc in scs for o in sc.obstacles if o.plane == "horizontal"
                   and not impassable_obstacles(sc))
    assert passable >= 2  # and bars the robot can duck under or walk under


def _stop_offsets(sc):
    """Per mover: (distance of its stop from the straight path, along-path station)."""
    start, goal = np.asarray(sc.robot.position), np.asarray(sc.goal.position)
    length = float(np.linalg.norm(goal - start))
    t = (goal - start) / length
    out = []
    for o in sc.obstacles:
        if rs.moving(o):
            stop = np.asarray(o.motion.waypoints[-1][:2]) - start
            out.append((abs(stop[0] * t[1] - stop[1] * t[0]) - max(o.semi_axes),
                        float(stop @ t) / length))
    return out


def test_walkers_stop_anywhere_on_or_next_to_the_path(drawn):
    _, scs = drawn
    offsets = [d for sc in scs for d, u in _stop_offsets(sc) if 0.0 < u < 1.0]
    assert sum(1 for d in offsets if d < 1.0) >= 20  # within 1 m of the path
    assert sum(1 for d in offsets if d < 0.0) >= 5  # on it
    after = [a for sc in scs for _, a in rs.meeting_walks(sc).values()]
    assert sum(1 for a in after if a < 0.5) >= 5  # stopping where the robot meets them


def test_walks_may_cross_the_start(drawn):
    _, scs = drawn
    assert sum(1 for sc in scs if rs.start_goal_clearance(sc)[0] < 0.5) >= 3


def test_no_passage_rule_and_elongated_shapes(drawn):
    _, scs = drawn
    profile = rs.profile_for(drawn[0])
    assert sum(1 for sc in scs if rs.passages(sc) < profile.passage) >= 10
    shapes = Counter(o.id.rsplit("_", 1)[0] for sc in scs for o in sc.obstacles)
    assert shapes["wall"] + shapes.get("side_wall", 0) >= 3
    assert shapes["bench"] + shapes["side_bench"] >= 3
    walls = [o for sc in scs for o in sc.obstacles if "wall" in o.id]
    assert all(max(o.semi_axes) / min(o.semi_axes) > 5 for o in walls)
    assert any(math.isfinite(rs.passages(sc)) for sc in scs)
