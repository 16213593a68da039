"""A 2-D LiDAR scan clears the coasting tracks whose place it sees empty (no ROS)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from safe_legged_c3bf.perception.scan_clearing import (
    ClearingConfig,
    ScanPlacer,
    seen_free,
    seen_through,
)
from safe_legged_c3bf.perception.track import Detection, ObstaclePlane
from safe_legged_c3bf.perception.tracker import MultiObstacleTracker, TrackerConfig

BEAMS = 360
ANGLE_MIN = -math.pi
INCREMENT = 2.0 * math.pi / BEAMS
PLANE_Z = 0.4  # m: the LiDAR's height in odom in these tests


def _pose(x: float = 0.0, y: float = 0.0, yaw: float = 0.0, z: float = PLANE_Z) -> np.ndarray:
    out = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    out[:2, :2] = [[c, -s], [s, c]]
    out[:3, 3] = (x, y, z)
    return out


def _ranges(wall: float = 3.0) -> np.ndarray:
    """Every beam ends on a round wall ``wall`` m away."""
    return np.full(BEAMS, wall)


def _beam(bearing: float) -> int:
    return int(round((bearing - ANGLE_MIN) / INCREMENT)) % BEAMS


def _scan(ranges: np.ndarray, stamp: float = 1.0, pose: np.ndarray | None = None):
    return seen_free(stamp, _pose() if pose is None else pose, ANGLE_MIN, INCREMENT, ranges,
                     0.1, 8.0)


def test_readings_follow_rep_117_and_the_lidar_pose():
    r = _ranges()
    r[0], r[1], r[2], r[3] = math.inf, math.nan, 0.05, -math.inf
    seen = _scan(r, pose=_pose(yaw=math.pi / 2))
    assert seen.reach[0] == 8.0  # no return within range_max: free up to it
    assert np.isnan(seen.reach[1:4]).all()  # dropped, too near, -inf: unknown
    assert seen.reach[10] == pytest.approx(3.0)
    # the LiDAR faces odom +y: its beam along its own x axis points along odom +y
    assert seen.bearings[_beam(0.0)] == pytest.approx(math.pi / 2)
    assert np.allclose(seen.origin, (0.0, 0.0, PLANE_Z))


def test_beams_through_the_core_clear_it_and_one_return_inside_keeps_it():
    config = ClearingConfig()
    center = np.array([1.5, 0.0])
    assert seen_through(_scan(_ranges()), center, 0.2, 1.0, config)
    r = _ranges()
    r[_beam(0.0)] = 1.45  # something at the core's near side
    assert not seen_through(_scan(r), center, 0.2, 1.0, config)
    r = _ranges()
    r[_beam(0.0) - 15:_beam(0.0) + 16] = 1.2  # something hides the core
    assert not seen_through(_scan(r), center, 0.2, 1.0, config)


def test_too_few_readable_beams_or_a_low_top_or_no_room_say_nothing():
    config = ClearingConfig()
    center = np.array([1.5, 0.0])
    r = _ranges()
    r[_beam(0.0) - 10:_beam(0.0) + 11] = math.nan  # the beams across the core dropped
    assert not seen_through(_scan(r), center, 0.2, 1.0, config)
    # a bench whose top is below the scan plane: the LiDAR passes over it
    assert not seen_through(_scan(_ranges()), center, 0.2, PLANE_Z - 0.1, config)
    assert seen_through(_scan(_ranges()), center, 0.2, PLANE_Z - 0.02, config)
    # the wall behind is closer than the core's far side plus the margin
    assert not seen_through(_scan(_ranges(1.75)), center, 0.2, 1.0, config)
    # the LiDAR inside the core
    assert not seen_through(_scan(_ranges()), np.array([0.1, 0.0]), 0.2, 1.0, config)


def test_the_placer_needs_a_pose_and_places_the_scan_by_mount_and_odometry():
    mount = np.eye(4)
    mount[:3, 3] = (0.1, 0.0, 0.1)
    placer = ScanPlacer(mount)
    assert placer.seen_free(1.0, ANGLE_MIN, INCREMENT, _ranges(), 0.1, 8.0) is None
    yaw = math.pi / 2
    placer.add_pose(1.0, (2.0, 0.0, 0.3), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)))
    seen = placer.seen_free(1.0, ANGLE_MIN, INCREMENT, _ranges(), 0.1, 8.0)
    assert np.allclose(seen.origin, (2.0, 0.1, 0.4))
    assert seen.bearings[_beam(0.0)] == pytest.approx(yaw)
    assert placer.seen_free(5.0, ANGLE_MIN, INCREMENT, _ranges(), 0.1, 8.0) is None  # no pose


def _phantom_tracker(
    clearing: bool, speed: float = 0.6, start: float = 2.0
) -> MultiObstacleTracker:
    """A confirmed track from ``start`` m ahead coming at ``speed`` m/s; then no detections.

    The robot walks (its near tracks are kept up to keep_near_max_coast_time).
    """
    tracker = MultiObstacleTracker(TrackerConfig(scan_clearing=clearing))
    tracker.observe_robot((0.0, 0.0, 0.0), 0.2)
    for k in range(8):
        x = start - 0.1 * speed * k
        det = Detection(center=(x, 0.0, 0.5), semi_axes=(0.2, 0.15), orientation=0.0,
                        plane=ObstaclePlane.VERTICAL, extent=1.0)
        tracker.update([det], 0.1 * k)
    assert [o.velocity[0] < -0.5 * speed for o in tracker.tracks_at(0.7)] == [True]
    return tracker


def _coast(tracker: MultiObstacleTracker, ranges: np.ndarray, until: float) -> list[float]:
    """Scans and empty detection batches at 10 Hz; the times the track was published."""
    seen_at = []
    for k in range(8, int(until * 10)):
        t = 0.1 * k
        tracker.clear_seen_through(_scan(ranges, stamp=t))
        tracker.update([], t)
        if tracker.tracks_at(t):
            seen_at.append(t)
    return seen_at


def test_a_phantom_that_coasts_into_view_is_cleared():
    kept = _coast(_phantom_tracker(clearing=False), _ranges(), 3.0)
    assert kept and kept[-1] == pytest.approx(2.9)  # kept near the walking robot
    cleared = _coast(_phantom_tracker(clearing=True), _ranges(), 3.0)
    # unseen for clear_after (0.25 s), then two scans in a row
    assert cleared and cleared[-1] < 1.2


def test_an_obstacle_the_scan_still_sees_is_not_cleared():
    r = _ranges()
    r[_beam(0.0) - 12:_beam(0.0) + 13] = 1.3  # its near side: the detector misses it
    kept = _coast(_phantom_tracker(clearing=True, speed=0.05, start=1.5), r, 3.0)
    assert kept and kept[-1] == pytest.approx(2.9)


def test_a_scan_clears_nothing_when_off_or_with_a_non_finite_stamp():
    tracker = _phantom_tracker(clearing=True)
    assert tracker.clear_seen_through(_scan(_ranges(), stamp=math.nan)) == []
    off = _phantom_tracker(clearing=False)
    assert off.clear_seen_through(_scan(_ranges(), stamp=2.0)) == []
    assert off.clear_seen_through(_scan(_ranges(), stamp=2.1)) == []
    assert len(off.tracks) == 1


def test_the_trackers_defaults_are_the_modules():
    assert TrackerConfig().clearing() == ClearingConfig()
