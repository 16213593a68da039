"""Replay KPIs on hand-made cycles and ground truth: cone entries, reactions, free path."""

from __future__ import annotations

import numpy as np

from safe_legged_c3bf.replay.kpis import FilterCycles, GroundTruth, KpiLimits, score

DT = 0.01


def _truth(duration: float, pillar_x: float | None = 3.0) -> GroundTruth:
    """Robot standing at the origin facing +x; one static pillar (radius 0.2 m) ahead."""
    t = np.arange(0.0, duration, DT)
    pose = np.zeros((t.size, 5))
    obs = np.array([[pillar_x, 0.0, 0.0, 0.0, 0.2]]) if pillar_x is not None else np.zeros((0, 5))
    return GroundTruth(t, pose, t.copy(), [obs] * t.size)


def _cycles(duration: float, ref_on: float, act_at: float | None, safe_out_at: float | None):
    """Reference 0.5 m/s ahead from ``ref_on``; the filter acts / turns away at the given times."""
    t = np.arange(0.0, duration, DT)
    ref = np.zeros((t.size, 3))
    ref[t >= ref_on, 0] = 0.5
    status = np.ones(t.size, int)
    safe = ref.copy()
    if act_at is not None:
        status[t >= act_at] = 2
    if safe_out_at is not None:
        safe[t >= safe_out_at] = [0.0, 0.0, 0.5]  # stop and turn: out of the cone
    return FilterCycles(t, status, ref, safe)


def test_reaction_and_cone_exit_are_measured_from_the_cone_entry():
    rep = score(_cycles(5.0, 2.0, 2.12, 2.3), _truth(5.0), pad=0.25)
    assert rep.entries == 1 and rep.missed == 0
    assert abs(rep.reaction[0] - 0.12) < 1.5 * DT
    assert abs(rep.cone_exit[0] - 0.30) < 1.5 * DT
    assert rep.passed, rep.failures


def test_a_slow_filter_fails_its_limits_and_says_why():
    rep = score(_cycles(5.0, 2.0, 2.5, 2.9), _truth(5.0), pad=0.25)
    assert not rep.passed
    assert any("reaction" in f for f in rep.failures)
    assert any("cone exit" in f for f in rep.failures)


def test_no_reaction_at_all_is_a_missed_entry():
    rep = score(_cycles(8.0, 2.0, None, None), _truth(8.0), pad=0.25)
    assert rep.entries == 1 and rep.missed == 1 and not rep.passed


def test_acting_on_a_free_path_counts_as_false_intervention():
    # no obstacle at all: every acting cycle after the warm-up is a false intervention
    cycles = _cycles(5.0, 0.0, 3.0, None)
    rep = score(cycles, _truth(5.0, pillar_x=None), pad=0.25)
    assert rep.entries == 0
    assert abs(rep.false_intervention_share - 0.5) < 0.02
    assert not rep.passed
    quiet = score(_cycles(5.0, 0.0, None, None), _truth(5.0, pillar_x=None), pad=0.25)
    assert quiet.false_intervention_share == 0.0 and quiet.passed


def test_an_obstacle_beyond_the_sensing_range_is_no_cone_entry():
    rep = score(_cycles(5.0, 2.0, None, None), _truth(5.0, pillar_x=9.0), pad=0.25,
                limits=KpiLimits(sensing_range=4.0))
    assert rep.entries == 0 and rep.passed


def test_nothing_to_score_fails():
    empty = FilterCycles(np.zeros(0), np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3)))
    rep = score(empty, _truth(1.0), pad=0.25)
    assert not rep.passed
