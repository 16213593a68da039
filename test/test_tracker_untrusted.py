"""The tracker under untrusted detections: two publishers, drop-outs near the robot, floods."""

import numpy as np

from safe_legged_c3bf.perception import Detection, MultiObstacleTracker, TrackerConfig

DT = 0.05
WALKER = Detection((1.5, 0.0, 0.5), (0.25, 0.25))


def confirmed(tracker, t):
    return tracker.tracks_at(t)


def track_walker(tracker, until, start=0.0):
    t = start
    while t < until - 1e-9:
        tracker.update([WALKER], t)
        t += DT
    return t


def test_a_second_publisher_with_empty_frames_never_deletes_tracks():
    tracker = MultiObstacleTracker()
    t = track_walker(tracker, 1.0)
    # From now on a second detector sends empty frames, slightly newer than the real ones.
    for _ in range(60):
        tracker.update([], t + 0.02)  # second publisher: ahead of the real one
        tracker.update([WALKER], t)  # the real one: slightly older, merged not rejected
        t += DT
    assert [o.id for o in confirmed(tracker, t)] == ["track_1"]
    assert tracker.rejection_counts["stale_timestamp"] == 0


def test_batches_older_than_max_reorder_are_rejected_whole():
    cfg = TrackerConfig()
    tracker = MultiObstacleTracker(cfg)
    track_walker(tracker, 1.0)
    last = tracker.last_update_time  # the newest batch's stamp
    report = tracker.update([WALKER, WALKER], last - cfg.max_reorder - 0.01)
    assert report.accepted == 0
    assert tracker.rejection_counts["stale_timestamp"] == 2
    report = tracker.update([WALKER], last - cfg.max_reorder + 0.01)  # within: merged
    assert report.accepted == 1 and report.matched == 1


def test_a_track_near_the_moving_robot_coasts_growing_until_the_robot_stops():
    cfg = TrackerConfig()
    tracker = MultiObstacleTracker(cfg)
    tracker.observe_robot((0.5, 0.0, 0.3), speed=0.4)
    t = track_walker(tracker, 1.0)
    size = confirmed(tracker, t)[0].semi_axes[0]
    lost = t  # drop-out: the detector keeps publishing frames without the walker
    while t < lost + 3.0:
        tracker.update([], t)
        t += DT
    (obs,) = confirmed(tracker, t)  # kept far past max_coast_time (1 s)
    assert t - lost > cfg.track.max_coast_time + 1.5
    expected = cfg.coast_growth * (t - (lost - DT) - cfg.coast_growth_after)
    assert obs.semi_axes[0] - size > 0.5 * expected > 0.2  # grown: it may have moved
    tracker.observe_robot((0.5, 0.0, 0.3), speed=0.0)  # the robot has stopped
    tracker.update([], t)
    assert confirmed(tracker, t) == []


def test_a_track_far_from_the_robot_is_deleted_after_its_coast_time():
    cfg = TrackerConfig()
    tracker = MultiObstacleTracker(cfg)
    tracker.observe_robot((-5.0, 0.0, 0.3), speed=0.4)  # 6.5 m away: not near
    t = track_walker(tracker, 1.0)
    lost = t
    while t < lost + cfg.track.max_coast_time + 0.2:
        tracker.update([], t)
        t += DT
    assert confirmed(tracker, t) == []


def test_a_near_track_is_kept_at_most_keep_near_max_coast_time():
    cfg = TrackerConfig(keep_near_max_coast_time=2.0)
    tracker = MultiObstacleTracker(cfg)
    tracker.observe_robot((0.5, 0.0, 0.3), speed=0.4)
    t = track_walker(tracker, 1.0)
    lost = t
    while t < lost + 2.5:
        tracker.update([], t)
        t += DT
    assert confirmed(tracker, t) == []


def test_a_flood_of_detections_keeps_the_nearest_and_counts_the_rest():
    cfg = TrackerConfig(max_detections=64)
    tracker = MultiObstacleTracker(cfg)
    rng = np.random.default_rng(0)
    far = [Detection((x, y, 0.5), (0.2, 0.2)) for x, y in rng.uniform(5, 14, size=(9999, 2))]
    near = Detection((1.0, 0.2, 0.5), (0.3, 0.3))
    report = tracker.update([*far[:5000], near, *far[5000:]], 0.0, robot_position=(0.0, 0.0))
    assert report.accepted == 64
    assert tracker.rejection_counts["too_many"] == 10000 - 64
    kept = [tuple(np.round(trk.kf.state_at(0.0)[0][:2], 3)) for trk in tracker.tracks]
    assert (1.0, 0.2) in kept
    assert {k for k, reason in report.rejected if reason.value == "too_many"}.isdisjoint({5000})
