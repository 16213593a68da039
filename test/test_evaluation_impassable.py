"""Impassable obstacles from geometry, and the held stop expected before them."""

from __future__ import annotations

import numpy as np
import pytest

from safe_legged_c3bf.evaluation.impassable import (
    BodyEnvelope,
    bar_impassable,
    body_envelope,
    gap_impassable,
    held_stop,
    impassable_obstacles,
    surface_gap,
)
from safe_legged_c3bf.sim.scenario import load_scenario, parse_scenario

A1 = BodyEnvelope("quadruped", 0.30, 0.057, 0.18)


def scenario(obstacles, robot="quadruped", filt=None, goal=(5.0, 0.0)):
    data = {"name": "t", "robot": {"kind": robot}, "goal": {"position": list(goal)},
            "duration": 25.0, "obstacles": obstacles}
    if filt:
        data["filter"] = filt
    return parse_scenario(data, name="t")


def bar(underside, x=2.5, radius=0.05, y=0.0, extent=4.0):
    return {"id": "bar", "plane": "horizontal", "position": [x, y, underside + radius],
            "semi_axes": [radius, radius], "extent": extent}


def test_envelope_from_filter_min_height_and_the_controller_floor():
    # Filter default min_height 0.20 (config) is above the A1 controller's 0.18: it counts.
    assert body_envelope(scenario([])).lowest_base == pytest.approx(0.20)
    low = body_envelope(scenario([], filt={"min_height": 0.18, "max_height": 0.285}))
    assert low.lowest_top == pytest.approx(0.18 + 0.057)
    # The biped cannot duck: a filter that thinks it can (min_height 0.7) does not lower it.
    biped = body_envelope(scenario([], robot="biped", goal=(3.0, 0.0),
                                   filt={"min_height": 0.7, "max_height": 0.9}))
    assert biped.lowest_base == pytest.approx(0.80) and biped.trunk_top == pytest.approx(0.23)


def test_bar_and_gap_rules():
    assert bar_impassable(0.20, A1) and not bar_impassable(0.25, A1)
    assert gap_impassable(0.25, A1) and not gap_impassable(0.35, A1)
    # With the filter's clearance: 4 cm over the trunk top, 4 cm on each side of the body.
    kept = BodyEnvelope("quadruped", 0.30, 0.057, 0.18, clearance=0.04)
    assert bar_impassable(0.27, kept) and not bar_impassable(0.27, kept, clearance=False)
    assert not bar_impassable(0.28, kept)
    assert gap_impassable(0.37, kept) and not gap_impassable(0.37, kept, clearance=False)
    assert not gap_impassable(0.39, kept)


def test_a_bar_passable_only_without_the_filters_clearance_is_held_for():
    """Underside 2 cm above the bare trunk top, 2 cm short of the clearance: by margin."""
    filt = {"min_height": 0.18, "max_height": 0.285, "safety_margin": 0.03}
    env = body_envelope(scenario([], filt=filt))
    assert env.clearance == pytest.approx(0.04)  # safety_margin + the QP's DEFAULT_MARGIN
    (blk,) = impassable_obstacles(scenario([bar(0.257)], filt=filt))
    assert blk.by_margin and "bare trunk would pass" in blk.reason
    (low,) = impassable_obstacles(scenario([bar(0.20)], filt=filt))
    assert not low.by_margin
    assert impassable_obstacles(scenario([bar(0.28)], filt=filt)) == []


def test_bars_on_the_path_by_height():
    filt = {"min_height": 0.18, "max_height": 0.285}
    (blk,) = impassable_obstacles(scenario([bar(0.20)], filt=filt))
    assert blk.kind == "bar" and blk.ids == ("bar",)
    assert blk.station == pytest.approx(2.45)
    # 0.26 m clears the bare trunk top (0.237 m), not the filter's default clearance (0.06 m).
    (margin,) = impassable_obstacles(scenario([bar(0.26)], filt=filt))
    assert margin.by_margin
    assert impassable_obstacles(scenario([bar(0.30)], filt=filt)) == []
    # Not across the path: its end stops 0.1 m past the path, less than half the body.
    assert impassable_obstacles(scenario([bar(0.20, y=2.1, extent=4.0)], filt=filt)) == []


def test_gaps_between_two_obstacles():
    def wall(y, oid):
        return {"id": oid, "position": [3.0, y], "semi_axes": [1.0, 0.1],
                "orientation": 1.5707963}

    narrow = scenario([wall(-1.1, "r"), wall(1.1, "l")])  # gap 0.2 m on the path
    gap, _, _ = surface_gap(*narrow.obstacles)
    assert gap == pytest.approx(0.2, abs=0.01)
    (blk,) = impassable_obstacles(narrow)
    assert blk.kind == "gap" and set(blk.ids) == {"r", "l"}
    assert blk.station == pytest.approx(2.9, abs=0.01)
    assert impassable_obstacles(scenario([wall(-1.25, "r"), wall(1.25, "l")])) == []  # 0.5 m
    beside = scenario([wall(1.0, "r"), wall(3.2, "l")])  # narrow, but left of the path
    assert impassable_obstacles(beside) == []


def test_named_scenarios():
    assert [b.kind for b in impassable_obstacles(load_scenario("quadruped_low_bar"))] == ["bar"]
    assert [b.kind for b in impassable_obstacles(load_scenario("biped_low_bar"))] == ["bar"]
    for name in ("quadruped_horizontal", "quadruped_bar_rising", "quadruped_gap",
                 "quadruped_wall", "quadruped_crowd", "biped_crowd"):
        assert impassable_obstacles(load_scenario(name)) == [], name


def odom(xs, dt=0.1):
    t = np.arange(len(xs)) * dt
    return np.column_stack([t, xs, np.zeros(len(xs))])


def test_held_stop_and_creep():
    sc = scenario([bar(0.20)], filt={"min_height": 0.18, "max_height": 0.285})
    blockers = impassable_obstacles(sc)
    walk = list(np.linspace(0.0, 1.9, 60))
    held = held_stop(sc, odom(walk + [1.9] * 100), blockers)
    assert held.held and held.creep == pytest.approx(0.0) and held.margin > 0.5
    creeping = held_stop(sc, odom(walk + list(np.linspace(1.9, 2.0, 100))), blockers)
    assert not creeping.held and creeping.creep > 0.05
    # Swaying in place (2 cm) is not creeping.
    sway = walk + list(1.9 + 0.02 * np.sin(np.arange(100)))
    assert held_stop(sc, odom(sway), blockers).held
    past = held_stop(sc, odom(list(np.linspace(0.0, 4.0, 200))), blockers)
    assert not past.held and past.margin < 0
    assert held_stop(sc, odom([0.0, 0.1]), blockers) is None  # shorter than the window
    assert held_stop(sc, odom(walk + [1.9] * 100), []) is None
