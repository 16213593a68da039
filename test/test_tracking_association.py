"""Unit tests of detection-to-track association."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safe_legged_c3bf.perception.association import (
    associate,
    gate_threshold,
    gated_assignment,
    mahalanobis_cost_matrix,
)

GATE = gate_threshold(0.9999, 3)


def test_gate_threshold_is_chi_square_quantile():
    assert gate_threshold(0.99, 3) == pytest.approx(11.3449, rel=1e-4)
    assert gate_threshold(0.95, 2) == pytest.approx(5.9915, rel=1e-4)
    with pytest.raises(ValueError):
        gate_threshold(1.0)


def test_mahalanobis_cost_matrix_values():
    predicted = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    covs = np.array([np.eye(3) * 0.01, np.diag([0.04, 0.01, 0.01])])
    measured = np.array([[0.1, 0.0, 0.0], [1.0, 0.2, 0.0], [5.0, 5.0, 5.0]])
    cost = mahalanobis_cost_matrix(predicted, covs, measured)
    assert cost.shape == (2, 3)
    assert cost[0, 0] == pytest.approx(1.0)
    assert cost[1, 1] == pytest.approx(4.0)
    assert cost[1, 0] == pytest.approx(0.81 / 0.04)
    assert mahalanobis_cost_matrix(predicted, covs, np.zeros((0, 3))).shape == (2, 0)


def test_global_assignment_beats_greedy():
    # Greedy would give track 0 detection 0 (cost 1) and leave track 1 with 10.
    cost = np.array([[1.0, 2.0], [2.0, 10.0]])
    assert sorted(gated_assignment(cost, gate=20.0)) == [(0, 1), (1, 0)]


def test_gate_forbids_far_pairs():
    cost = np.array([[1.0, 50.0], [60.0, 70.0]])
    assert gated_assignment(cost, gate=GATE) == [(0, 0)]
    assert gated_assignment(np.full((2, 2), np.inf), gate=GATE) == []
    assert gated_assignment(np.zeros((0, 3)), gate=GATE) == []


def test_ids_take_priority_over_distance():
    # Detection "b" is next to track "a" but identities win.
    cost = np.array([[0.1, 9.0], [9.0, 0.1]])
    res = associate(["b", "a"], [0, 0], ["a", "b"], [0, 0], cost, GATE)
    assert res.matches == [(0, 1), (1, 0)]
    assert res.by_id == 2
    assert res.unmatched_tracks == [] and res.unmatched_detections == []


def test_anonymous_detection_uses_nearest_neighbour_and_unknown_id_starts_track():
    cost = np.array([[0.5, 3.0, 0.2]])
    res = associate([""], [0], ["", "", "new"], [0, 0, 0], cost, GATE)
    # "new" may adopt the anonymous track; it is the cheapest pair.
    assert res.matches == [(0, 2)]
    assert res.unmatched_detections == [0, 1]
    res = associate(["old"], [0], ["", "new"], [0, 0], np.array([[3.0, 0.2]]), GATE)
    # An identified track never takes a detection with another identity.
    assert res.matches == [(0, 0)]
    assert res.unmatched_detections == [1]


def test_planes_are_not_mixed():
    cost = np.array([[0.1]])
    res = associate([""], [0], [""], [1], cost, GATE)
    assert res.matches == []
    assert res.unmatched_tracks == [0] and res.unmatched_detections == [0]


@settings(max_examples=50, deadline=None)
@given(
    st.integers(0, 5),
    st.integers(0, 5),
    st.randoms(use_true_random=False),
)
def test_result_is_a_partition(n, m, rnd):
    cost = np.array([[rnd.uniform(0, 40) for _ in range(m)] for _ in range(n)]).reshape(n, m)
    track_ids = [rnd.choice(["", "a", "b", "c", "d", "e"]) for _ in range(n)]
    track_ids = [tid if tid not in track_ids[:i] else "" for i, tid in enumerate(track_ids)]
    det_ids = [rnd.choice(["", "a", "b", "x", "y"]) for _ in range(m)]
    det_ids = [d if d not in det_ids[:j] else "" for j, d in enumerate(det_ids)]
    tp = [rnd.randint(0, 1) for _ in range(n)]
    dp = [rnd.randint(0, 1) for _ in range(m)]
    res = associate(track_ids, tp, det_ids, dp, cost, GATE)
    tracks = [i for i, _ in res.matches] + res.unmatched_tracks
    dets = [j for _, j in res.matches] + res.unmatched_detections
    assert sorted(tracks) == list(range(n))
    assert sorted(dets) == list(range(m))
    for i, j in res.matches:
        if det_ids[j] and track_ids[i]:
            assert det_ids[j] == track_ids[i]
        elif det_ids[j] not in track_ids or not det_ids[j]:
            assert cost[i, j] <= GATE and tp[i] == dp[j]
