"""Scenario tests of the multi-obstacle tracker (30 Hz detections, 2 cm noise)."""

import math

import numpy as np
import pytest

from safe_legged_c3bf.perception.track import Detection, ObstaclePlane, TrackConfig
from safe_legged_c3bf.perception.tracker import (
    MultiObstacleTracker,
    RejectionReason,
    TrackerConfig,
)

RATE = 30.0
DT = 1.0 / RATE
NOISE = 0.02


def simulate(obstacles, duration, seed, *, dropout=0.0, ids=False, tracker=None, on_step=None):
    """Run the tracker on constant-velocity obstacles ``[(p0, v), ...]``.

    Each detection is dropped independently with probability ``dropout``.  ``on_step`` is
    called as ``on_step(t, truth_positions, truth_velocities, tracker)`` after each update.
    """
    rng = np.random.default_rng(seed)
    tracker = tracker or MultiObstacleTracker()
    p0 = np.array([o[0] for o in obstacles], dtype=float)
    v = np.array([o[1] for o in obstacles], dtype=float)
    for k in range(int(round(duration * RATE)) + 1):
        t = k * DT
        p = p0 + v * t
        dets = [
            Detection(
                center=p[i] + rng.normal(0.0, NOISE, 3),
                semi_axes=(0.3, 0.3),
                id=f"obs{i}" if ids else "",
            )
            for i in range(len(obstacles))
            if rng.random() >= dropout
        ]
        tracker.update(dets, t)
        if on_step is not None:
            on_step(t, p, v, tracker)
    return tracker


def nearest_track(tracks, position):
    return min(tracks, key=lambda o: np.linalg.norm(o.center - position))


def test_velocity_rms_error_after_one_second():
    """0.5 m/s obstacle: RMS of |v_est - v_true| (3D) over 30 seeds x all steps in [1 s, 4 s]."""
    errors = []

    def record(t, p, v, tracker):
        if t >= 1.0 - 1e-9:
            tracks = tracker.tracks_at(t)
            assert len(tracks) == 1
            assert tracks[0].velocity_estimated
            errors.append(np.linalg.norm(tracks[0].velocity - v[0]))

    for seed in range(30):
        heading = 2 * math.pi * seed / 30
        v = 0.5 * np.array([math.cos(heading), math.sin(heading), 0.0])
        simulate([((2.0, 0.0, 0.5), v)], 4.0, seed, on_step=record)
    rms = float(np.sqrt(np.mean(np.square(errors))))
    assert len(errors) == 30 * 91
    assert rms <= 0.05, rms


def test_static_obstacles_report_small_speed():
    """Static obstacles: RMS and mean of |v| (3D) over 20 seeds x 3 obstacles x [1 s, 4 s]."""
    speeds = []

    def record(t, p, v, tracker):
        if t >= 1.0 - 1e-9:
            tracks = tracker.tracks_at(t)
            assert len(tracks) == 3
            speeds.extend(o.speed for o in tracks)

    static = [
        ((1.0, 1.0, 0.3), (0, 0, 0)),
        ((3.0, -1.0, 0.5), (0, 0, 0)),
        ((5.0, 0.0, 1.0), (0, 0, 0)),
    ]
    for seed in range(20):
        simulate(static, 4.0, seed, on_step=record)
    speeds = np.array(speeds)
    assert float(np.sqrt(np.mean(speeds**2))) <= 0.03
    assert float(np.mean(speeds)) <= 0.03
    assert float(np.median(speeds)) <= 0.03


def test_no_track_lost_with_twenty_percent_dropouts():
    obstacles = [
        ((1.0, 2.0, 0.5), (0.5, -0.2, 0.0)),
        ((4.0, -1.0, 0.5), (-0.3, 0.4, 0.0)),
        ((3.0, 0.0, 0.8), (0.0, 0.0, 0.0)),
    ]
    for seed in range(10):
        confirmed_ids: list[set[int]] = []
        owners: dict[int, set[int]] = {0: set(), 1: set(), 2: set()}

        def record(t, p, v, tracker, confirmed_ids=confirmed_ids, owners=owners):
            if t < 0.5:
                return
            tracks = tracker.tracks_at(t)
            confirmed_ids.append({o.track_id for o in tracks})
            for i in range(3):
                owners[i].add(nearest_track(tracks, p[i]).track_id)

        tracker = simulate(obstacles, 8.0, seed, dropout=0.2, on_step=record)
        # The same three tracks from 0.5 s to the end, each following one obstacle.
        assert all(ids == confirmed_ids[0] for ids in confirmed_ids), seed
        assert len(confirmed_ids[0]) == 3
        assert all(len(s) == 1 for s in owners.values())
        assert len(set.union(*owners.values())) == 3
        assert len(tracker.tracks) == 3  # no spurious tentative tracks either


@pytest.mark.parametrize(
    ("va", "vb"),
    [
        ((0.35, 0.35, 0.0), (0.35, -0.35, 0.0)),  # 90 degree crossing
        ((0.5, 0.1, 0.0), (0.5, -0.1, 0.0)),  # shallow crossing, 23 degrees
        ((0.5, 0.0, 0.0), (-0.5, 0.0, 0.0)),  # head-on pass-through on the same line
    ],
    ids=["perpendicular", "shallow", "head_on"],
)
def test_crossing_anonymous_obstacles_keep_identities(va, vb):
    va, vb = np.array(va), np.array(vb)
    crossing = np.array([3.0, 0.0, 0.5])
    t_cross = 3.0  # both are exactly at `crossing` at t = 3 s
    obstacles = [(crossing - va * t_cross, va), (crossing - vb * t_cross, vb)]
    for seed in range(8):
        owner_a, owner_b = set(), set()

        def record(t, p, v, tracker, owner_a=owner_a, owner_b=owner_b):
            if t < 0.5 or abs(t - t_cross) < 0.5:
                return  # identities are only defined when the obstacles are apart
            tracks = tracker.tracks_at(t)
            assert len(tracks) == 2
            owner_a.add(nearest_track(tracks, p[0]).track_id)
            owner_b.add(nearest_track(tracks, p[1]).track_id)

        simulate(obstacles, 6.0, seed, on_step=record)
        assert len(owner_a) == 1 and len(owner_b) == 1, (seed, owner_a, owner_b)
        assert owner_a != owner_b


def test_identified_obstacles_follow_ids_even_when_swapping_places():
    tracker = MultiObstacleTracker()
    for k in range(10):
        t = k * DT
        tracker.update(
            [
                Detection((1.0, 0.0, 0.5), (0.3, 0.3), id="a"),
                Detection((1.0, 1.0, 0.5), (0.3, 0.3), id="b"),
            ],
            t,
        )
    # The detector reports the two obstacles at each other's place: ids win.
    tracker.update(
        [
            Detection((1.0, 1.0, 0.5), (0.3, 0.3), id="a"),
            Detection((1.0, 0.0, 0.5), (0.3, 0.3), id="b"),
        ],
        10 * DT,
    )
    by_id = {o.id: o for o in tracker.tracks_at(10 * DT)}
    assert set(by_id) == {"a", "b"}
    assert by_id["a"].hits == 11 and by_id["b"].hits == 11
    assert by_id["a"].center[1] > 0.05  # moved towards its new measurement


def test_tracks_at_predicts_and_drops_stale_tracks():
    v = np.array([0.5, 0.0, 0.0])
    tracker = simulate([((0.0, 0.0, 0.5), v)], 2.0, seed=1)
    now = tracker.tracks_at(2.0)[0]
    ahead = tracker.tracks_at(2.4)[0]
    np.testing.assert_allclose(ahead.center, now.center + 0.4 * now.velocity, atol=1e-9)
    assert np.trace(ahead.position_covariance) > np.trace(now.position_covariance)
    assert ahead.stamp == pytest.approx(2.4)
    # Detector silent: the track coasts for max_coast_time (1 s) and is then dropped.
    assert len(tracker.tracks_at(2.0 + 0.99)) == 1
    assert tracker.tracks_at(2.0 + 1.01) == []
    report = tracker.update([], 3.1)
    assert len(report.deleted) == 1 and tracker.tracks == []


def test_tentative_tracks_are_hidden_until_confirmed():
    tracker = MultiObstacleTracker()
    tracker.update([Detection((1.0, 0.0, 0.5), (0.3, 0.3))], 0.0)
    assert tracker.tracks_at(0.0) == []
    assert len(tracker.tracks_at(0.0, include_tentative=True)) == 1
    tracker.update([Detection((1.0, 0.0, 0.5), (0.3, 0.3))], DT)
    tracker.update([Detection((1.0, 0.0, 0.5), (0.3, 0.3))], 2 * DT)
    assert len(tracker.tracks_at(2 * DT)) == 1


def test_planes_are_tracked_separately():
    tracker = MultiObstacleTracker()
    for k in range(5):
        tracker.update(
            [
                Detection((2.0, 0.0, 0.5), (0.3, 0.3), plane=ObstaclePlane.VERTICAL),
                Detection((2.0, 0.0, 0.55), (1.0, 0.05), plane=ObstaclePlane.HORIZONTAL),
            ],
            k * DT,
        )
    planes = sorted(o.plane for o in tracker.tracks_at(5 * DT))
    assert planes == [ObstaclePlane.VERTICAL, ObstaclePlane.HORIZONTAL]


def test_bad_detections_are_rejected_and_counted_by_reason():
    tracker = MultiObstacleTracker(TrackerConfig(max_range=10.0))
    good = Detection((1.0, 0.0, 0.5), (0.3, 0.3), id="ok")
    bad = [
        Detection((math.nan, 0.0, 0.5), (0.3, 0.3)),  # non_finite
        Detection((1.0, math.inf, 0.5), (0.3, 0.3)),  # non_finite
        Detection((1.0, 0.0, 0.5), (0.3, math.nan)),  # non_finite
        Detection((1.0, 0.0, 0.5), (0.3, 0.3), orientation=math.inf),  # non_finite
        Detection((1.0, 0.0, 0.5), (0.0, 0.3)),  # non_positive_size
        Detection((1.0, 0.0, 0.5), (0.3, -0.1)),  # non_positive_size
        Detection((1.0, 0.0, 0.5), (30.0, 0.3)),  # too_large
        Detection((12.0, 0.0, 0.5), (0.3, 0.3)),  # out_of_range
        Detection((1.0, 0.0, 0.5), (0.3, 0.3), frame_id="base_link"),  # wrong_frame
        Detection((1.0, 0.0), (0.3, 0.3)),  # malformed
        Detection((1.0, 0.0, 0.5), (0.3, 0.3), plane=7),  # malformed
        Detection((1.5, 0.0, 0.5), (0.3, 0.3), id="ok"),  # duplicate_id
        Detection((1.0, 0.0, 0.5), (0.3, 0.3), extent=math.nan),  # non_finite
        Detection((1.0, 0.0, 0.5), (0.3, 0.3), extent=0.0),  # non_positive_size
    ]
    report = tracker.update([good, *bad], 0.0)
    assert report.accepted == 1
    assert [k for k, _ in report.rejected] == list(range(1, 15))
    counts = tracker.rejection_counts
    assert counts == {
        "malformed": 2,
        "non_finite": 5,
        "non_positive_size": 3,
        "too_large": 1,
        "wrong_frame": 1,
        "out_of_range": 1,
        "duplicate_id": 1,
        "stale_timestamp": 0,
        "too_many": 0,
    }
    assert len(tracker.tracks) == 1
    # Range is measured from the robot when its position is given.
    report = tracker.update(
        [Detection((12.0, 0.0, 0.5), (0.3, 0.3))], 0.1, robot_position=(5.0, 0.0)
    )
    assert report.accepted == 1
    # A batch older than max_reorder before the newest one is dropped as a whole.
    report = tracker.update([good, good], 0.1 - tracker.config.max_reorder - 1e-3)
    assert report.accepted == 0
    assert tracker.rejection_counts[RejectionReason.STALE_TIMESTAMP.value] == 2
    assert tracker.rejection_counts["out_of_range"] == 1


def test_config_validation():
    with pytest.raises(ValueError, match="max_range"):
        TrackerConfig(max_range=0.0)
    with pytest.raises(ValueError, match="gate_probability"):
        TrackerConfig(gate_probability=1.0)
    with pytest.raises(ValueError, match="gate_floor"):
        TrackerConfig(gate_floor=-0.1)
    with pytest.raises(ValueError, match="confirm_hits"):
        TrackerConfig(track=TrackConfig(confirm_hits=9))


def test_unusable_robot_position_falls_back_to_origin():
    tracker = MultiObstacleTracker(TrackerConfig(max_range=5.0))
    far = Detection((8.0, 0.0, 0.5), (0.3, 0.3))
    assert tracker.update([far], 0.0, robot_position=(math.nan, 0.0)).accepted == 0
    assert tracker.update([far], 0.1, robot_position=(6.0, 0.0, 0.0)).accepted == 1
