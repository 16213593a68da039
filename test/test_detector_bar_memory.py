"""The detector's bar memory on synthetic walks under a bar (no ROS, no simulator).

The A1 walks to a bar (quadruped_horizontal: axis x = 2.5 m, z = 0.35 m, radius 0.05 m),
ducks (base 0.22 m: its LiDAR at 0.317 m cuts the bar) and passes under it. From about 0.3 m
before the bar the forward 3-D sensor no longer sees it; only the bar memory keeps the
LiDAR's cut through it from being a wall on top of the robot.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from detector_frames import horizontal, inside_vertical, sensor_frames, vertical
from detector_scenes import Bar, Box, Pillar, Pose

from safe_legged_c3bf.interfaces.sensor_mounts import LIDAR_FRAME, default_mounts
from safe_legged_c3bf.perception.bar_memory import (
    MAX_REMEMBERED_BARS,
    MAX_STANDING_CELLS,
    BarMemory,
    on_line,
)
from safe_legged_c3bf.perception.detector import ObstacleDetector
from safe_legged_c3bf.perception.detector_config import DetectorConfig
from safe_legged_c3bf.perception.shapes import DetectedObstacle
from safe_legged_c3bf.perception.track import ObstaclePlane

MOUNTS = default_mounts("quadruped")
LIDAR_X = MOUNTS[LIDAR_FRAME].xyz[0]
BAR = Bar(2.5, z=0.35, radius=0.05)
STEP = 0.1  # s between frames


def frames(scene, pose, stamp, use_scan=True, use_cloud=True):
    """The A1's scan and cloud frames of ``scene`` from ``pose`` at ``stamp`` (odom exact)."""
    return sensor_frames(scene, "quadruped", pose, pose, stamp, use_scan, use_cloud)


def walk(bar_x):
    """Base poses walking to a bar at ``bar_x`` and under it: standing, then ducked.

    Poses that would put the LiDAR inside the bar (the ray caster has no collisions) are
    left out.
    """
    xs = np.round(np.arange(0.0, bar_x + 0.5, 0.1), 2)
    return [Pose(x=float(x), z=0.28 if x < bar_x - 0.9 else 0.22)
            for x in xs if abs(x + LIDAR_X - bar_x) > 0.06]


def run(scene, bar_x, config=None):
    """(pose, scan frame, report) of every frame of the walk, one detector throughout."""
    detector = ObstacleDetector(config)
    out = []
    for k, pose in enumerate(walk(bar_x)):
        scan_frame, cloud_frame = frames(scene, pose, 10.0 + STEP * k)
        out.append((pose, scan_frame, detector.detect(scan=scan_frame, cloud=cloud_frame)))
    return out


def the_bar(report, bar=BAR):
    """The one HORIZONTAL obstacle, checked to be ``bar`` (its place and its underside)."""
    [o] = horizontal(report)
    assert o.center[0] == pytest.approx(bar.x, abs=0.06)
    underside = bar.z - bar.radius
    assert underside - 0.05 <= o.center[2] - o.semi_axes[1] <= underside + 0.002
    return o


def test_ducking_under_a_bar_it_stays_a_bar_in_every_frame():
    frames_seen = run([BAR], BAR.x)
    unseen = 0
    for pose, scan_frame, report in frames_seen:
        assert not vertical(report), (pose, [o.center for o in vertical(report)])
        o = the_bar(report)
        assert o.extent > 3.5  # the whole bar the LiDAR cut on the way there
        if report.horizontal_clusters == 0:  # the 3-D sensor does not see it any more ...
            unseen += 1
            assert pose.x >= 2.0 and report.remembered_bars == 1
            cut = np.abs(scan_frame.points[:, 0] - BAR.x) < 0.1
            assert np.count_nonzero(cut) > 10  # ... while the LiDAR plane cuts it
            assert report.absorbed > 10
    assert unseen >= 6


def test_without_the_memory_the_bar_under_the_robot_is_a_wall():
    # bar_memory 0 is the detector before the memory: the same walk shows the bug.
    walls = [(pose, report) for pose, _, report in run([BAR], BAR.x, DetectorConfig(bar_memory=0.0))
             if vertical(report)]
    assert len(walls) >= 6
    for pose, report in walls:
        assert pose.x >= 2.0 and not horizontal(report)
        assert all(abs(o.center[0] - BAR.x) < 0.1 for o in vertical(report))


def test_scan_only_frames_lean_on_the_memory_but_the_first_frame_is_vertical():
    detector = ObstacleDetector()
    standing, ducked = Pose(x=1.0, z=0.28), Pose(x=2.2, z=0.22)
    # No cloud yet: the LiDAR's cut through the bar is something of unknown height: VERTICAL.
    scan_frame, _ = frames([BAR], standing, 10.0, use_cloud=False)
    first = detector.detect(scan=scan_frame)
    assert vertical(first) and not horizontal(first)
    assert all(abs(o.center[0] - BAR.x) < 0.1 for o in vertical(first))
    scan_frame, cloud_frame = frames([BAR], standing, 10.1)
    assert not vertical(detector.detect(scan=scan_frame, cloud=cloud_frame))
    # Under the bar, no cloud within cloud_max_age: the scan alone, the bar remembered.
    scan_frame, _ = frames([BAR], ducked, 10.5, use_cloud=False)
    report = detector.detect(scan=scan_frame)
    assert not vertical(report) and report.absorbed > 10
    the_bar(report)


def scan_points_near(scan_frame, x, y, radius):
    xy = scan_frame.points[:, :2]
    return xy[np.hypot(xy[:, 0] - x, xy[:, 1] - y) < radius]


def on_the_path(report, bar_x, half_width=0.2):
    """The VERTICAL obstacles across the robot's path (|y| <= half_width) at the bar."""
    path = np.column_stack([np.full(9, bar_x), np.linspace(-half_width, half_width, 9)])
    return [o for o in vertical(report) if inside_vertical(o, path).any()]


@pytest.mark.parametrize("pillar", [
    Pillar(2.5, 1.0, 0.2),  # under the bar, seen down to its foot on the way there
    Pillar(2.5, -1.8, 0.2, 1.7),  # a walker under the bar the 3-D sensor never sees
])
def test_what_stands_under_the_bar_stays_vertical(pillar):
    for pose, scan_frame, report in run([BAR, pillar], BAR.x):
        face = scan_points_near(scan_frame, pillar.x, pillar.y, pillar.radius + 0.005)
        covered = np.zeros(len(face), dtype=bool)
        for o in vertical(report):
            covered |= inside_vertical(o, face, grow=0.05)
        assert covered.all(), (pose, face[~covered])
        the_bar(report)
        assert not on_the_path(report, BAR.x), pose  # the bar itself is no wall


@pytest.mark.parametrize("bar_z", [0.35, 0.40])
def test_the_posts_holding_a_bar_stay_vertical_under_it(bar_z):
    # At 0.35 m the ducked LiDAR cuts the bar and the posts, at 0.40 m only the posts; the
    # 3-D sensor saw them down to the ground on the way, not from under the bar.
    bar = Bar(2.0, z=bar_z, radius=0.05, y0=-1.0, y1=1.0)
    scene = [bar, Box(2.0, -1.0, 0.1, 0.1, bar_z + 0.05), Box(2.0, 1.0, 0.1, 0.1, bar_z + 0.05)]
    for pose, scan_frame, report in run(scene, 2.0):
        for post_y in (-1.0, 1.0):
            face = scan_points_near(scan_frame, 2.0, post_y, 0.09)
            if len(face) == 0:
                continue  # hidden behind the other post's side (seen end-on)
            assert any(np.all(inside_vertical(o, face, grow=0.03)) for o in vertical(report)), (
                pose, post_y, face)
        the_bar(report, bar)
        assert not on_the_path(report, 2.0), pose


def test_a_memory_older_than_bar_memory_is_forgotten_by_age_alone_without_keep_near():
    detector = ObstacleDetector(DetectorConfig(bar_memory=1.0, bar_memory_keep_near=0.0))
    scan_frame, cloud_frame = frames([BAR], Pose(x=1.0, z=0.28), 10.0)
    detector.detect(scan=scan_frame, cloud=cloud_frame)
    under = Pose(x=2.2, z=0.22)
    for stamp, remembered in ((10.9, True), (11.2, False)):
        scan_frame, _ = frames([BAR], under, stamp, use_cloud=False)
        report = detector.detect(scan=scan_frame)
        assert bool(horizontal(report)) == remembered
        assert bool(vertical(report)) != remembered  # forgotten: the scan's cut is VERTICAL
    assert len(detector.memory) == 0


def test_a_bar_near_the_sensors_is_kept_past_bar_memory_until_they_leave_it():
    """Random biped seed 7 (sensors): stopped 1 m before a bar the forward sensor no longer
    saw, the biped stood 30 s, the bar was forgotten and it walked on. Near the sensors a bar
    stays remembered however old; it is forgotten by age once they are away from it."""
    cfg = DetectorConfig(bar_memory=1.0)
    detector = ObstacleDetector(cfg)
    scan_frame, cloud_frame = frames([BAR], Pose(x=1.0, z=0.28), 10.0)
    detector.detect(scan=scan_frame, cloud=cloud_frame)
    stopped = Pose(x=2.2, z=0.22)  # under the bar: the cloud does not see it
    for stamp in (10.9, 11.2, 40.0, 100.0):
        scan_frame, _ = frames([BAR], stopped, stamp, use_cloud=False)
        report = detector.detect(scan=scan_frame)
        assert horizontal(report) and not vertical(report), stamp  # still the bar
    gone = BarMemory()
    gone.update([bar(2.5)], 10.0, 1.0, 0.05)
    near = np.array([2.5 - 0.07 - cfg.bar_memory_keep_near + 0.01, 0.0])  # 1.99 m from its box
    gone.update([], 100.0, 1.0, 0.05, near, cfg.bar_memory_keep_near)
    assert len(gone) == 1
    gone.update([], 100.1, 1.0, 0.05, near - [0.02, 0.0], cfg.bar_memory_keep_near)
    assert len(gone) == 0  # 2.01 m away and 90 s old: forgotten
    gone.update([bar(2.5)], 10.0, 1.0, 0.05)  # a clock that goes back still forgets it
    gone.update([], 5.0, 1.0, 0.05, np.array([2.5, 0.0]), cfg.bar_memory_keep_near)
    assert len(gone) == 0


def test_a_clock_that_goes_back_or_clear_forgets_the_bars():
    detector = ObstacleDetector()
    scan_frame, cloud_frame = frames([BAR], Pose(x=1.0, z=0.28), 100.0)
    detector.detect(scan=scan_frame, cloud=cloud_frame)
    assert len(detector.memory) == 1
    scan_frame, _ = frames([BAR], Pose(x=2.2, z=0.22), 5.0, use_scan=True, use_cloud=False)
    report = detector.detect(scan=scan_frame)  # a new run: its stamps start again
    assert vertical(report) and not horizontal(report) and len(detector.memory) == 0
    scan_frame, cloud_frame = frames([BAR], Pose(x=1.0, z=0.28), 6.0)
    detector.detect(scan=scan_frame, cloud=cloud_frame)
    assert len(detector.memory) == 1
    detector.clear()
    assert len(detector.memory) == 0


def bar(x, y=0.0, z=0.35, extent=1.0, a=0.07, points=10):
    return DetectedObstacle(ObstaclePlane.HORIZONTAL, np.array([x, y, z]), (a, 0.05), 0.0,
                            extent, 1e-4 * np.eye(3), points)


def test_re_detections_merge_and_the_memory_is_bounded():
    memory = BarMemory()
    for k in range(50):  # the same bar seen from ever closer, a different part each time
        memory.update([bar(2.5 + 0.01 * (k % 3), y=0.02 * k)], 10.0 + 0.1 * k, 10.0, 0.05)
    [entry] = memory.bars
    lo, hi = entry.bounds()[1]
    assert lo == pytest.approx(-0.5) and hi == pytest.approx(0.5 + 0.02 * 49)
    assert entry.last_seen == pytest.approx(14.9)
    for k in range(3 * MAX_REMEMBERED_BARS):  # many different bars
        memory.update([bar(3.0 + 0.5 * k)], 20.0 + 0.01 * k, 10.0, 0.05)
    assert len(memory) == MAX_REMEMBERED_BARS
    assert min(b.obstacle.center[0] for b in memory.bars) > 3.0 + 0.5 * MAX_REMEMBERED_BARS
    # Standing columns are kept near bars only, and at most MAX_STANDING_CELLS of them.
    memory.update([bar(0.0, extent=100.0)], 30.0, 10.0, 0.05)
    posts = np.column_stack([np.zeros(20000), np.linspace(-49.0, 49.0, 20000),
                             np.full(20000, 0.35)])
    far = posts + [5.0, 0.0, 0.0]
    memory.stand(np.vstack([posts, far]), 30.0, 0.01, 0.05, 0.25)
    assert memory.standing(posts[:1, :2], 0.01).all()
    assert not memory.standing(far[:, :2], 0.01).any()
    assert memory._cells.size == MAX_STANDING_CELLS
    memory.update([], 45.0, 10.0, 0.05)  # 15 s later: everything is forgotten
    assert len(memory) == 0 and not memory.standing(posts[:, :2], 0.01).any()


def test_absorb_takes_the_bar_s_line_not_what_stands_in_its_band():
    memory = BarMemory()
    memory.update([bar(2.5, extent=4.0)], 10.0, 10.0, 0.05)
    y = np.arange(-1.9, 1.9, 0.03)
    line = np.column_stack([np.full(y.size, 2.46), y, np.full(y.size, 0.32)])
    t = np.linspace(-1.4, 1.4, 9)  # a pole (radius 0.1) on the line, all within the band
    pole = np.column_stack([2.5 - 0.1 * np.sin(t), 1.0 - 0.1 * np.cos(t), np.full(9, 0.32)])
    line = line[np.abs(line[:, 1] - 1.0) > 0.1]  # hidden behind the pole
    points = np.vstack([line, pole])
    n = len(line)
    owner = memory.absorb(points, np.ones(len(points), bool), np.zeros(len(points), bool),
                          0.05, 0.2, 0.1)
    assert np.all(owner[n:] == -1)  # off the line, and its neighbours guarded
    far = np.abs(line[:, 1] - 1.0) > 0.35
    assert np.all(owner[:n][far] == 0) and np.any(owner[:n][~far] == -1)
    # A point that stays VERTICAL (grounded) guards its neighbours within 0.2 m.
    anchor = np.zeros(len(points), bool)
    anchor[np.argmin(np.abs(line[:, 1] + 1.0))] = True
    owner = memory.absorb(points, ~anchor, anchor, 0.05, 0.2, 0.1)
    assert np.all(owner[:n][np.abs(line[:, 1] + 1.0) < 0.19] == -1)
    # A column seen standing up into the bar's band is never absorbed.
    memory.stand(np.array([[2.46, -1.5, 0.3], [2.46, 0.0, 0.05]]), 10.0, 0.1, 0.05, 0.25)
    owner = memory.absorb(points, np.ones(len(points), bool), np.zeros(len(points), bool),
                          0.05, 0.0, 0.1)
    assert np.all(owner[:n][np.abs(line[:, 1] + 1.5) < 0.1] == -1)
    assert np.all(owner[:n][np.abs(line[:, 1]) < 0.1] == 0)  # below the band: not standing


def test_the_line_of_a_bar_s_cut_leaves_an_arc_out():
    y = np.linspace(-1.5, 1.5, 61)
    line = np.column_stack([2.45 + 0.1 * y + 0.005 * np.sin(7 * y), y])  # slanted 6 degrees
    t = np.linspace(-1.5, 1.5, 15)  # a pillar touching the line, seen from the line's side
    arc = np.column_stack([2.5 + 0.2 - 0.2 * np.cos(t), 0.5 + 0.2 * np.sin(t)])
    keep = on_line(np.vstack([line, arc]), 0.05)
    assert keep[: len(line)].all()
    off = ~keep[len(line):]
    assert np.count_nonzero(off) >= 8 and off[0] and off[-1]  # the arc's flanks
    assert on_line(line[:2], 0.05).all()  # too few points for a line


@pytest.mark.parametrize("kwargs,name", [
    ({"bar_memory": -1.0}, "bar_memory"),
    ({"bar_memory": math.inf}, "bar_memory"),
    ({"bar_memory_tolerance": -0.01}, "bar_memory_tolerance"),
])
def test_config_errors_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}\b"):
        DetectorConfig(**kwargs)
