"""The obstacle detector on synthetic scans and clouds (no ROS, no simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from detector_frames import horizontal, inside_vertical, sensor_frames, vertical
from detector_scenes import Bar, Box, Pillar, Pose, scan, scan_angles

from safe_legged_c3bf.interfaces.sensor_mounts import DEPTH_FRAME, LIDAR_FRAME, default_mounts
from safe_legged_c3bf.perception.detector import ObstacleDetector
from safe_legged_c3bf.perception.detector_config import DetectorConfig
from safe_legged_c3bf.perception.pose_history import PoseHistory
from safe_legged_c3bf.perception.self_filter import default_self_box
from safe_legged_c3bf.perception.sensor_frame import make_frame
from safe_legged_c3bf.perception.sensor_points import scan_points
from safe_legged_c3bf.perception.shapes import split_pieces
from safe_legged_c3bf.perception.track import ObstaclePlane

STAMP = 10.0
BASE_Z = {"quadruped": 0.28, "biped": 0.81}


def frames(scene, kind="quadruped", pose=None, odom=None, use_scan=True, use_cloud=True,
           noise=0.0, seed=0):
    """Scan and cloud frames of ``scene`` seen from ``pose``; the detector believes ``odom``."""
    pose = pose or Pose(z=BASE_Z[kind])
    return sensor_frames(scene, kind, pose, odom or pose, STAMP, use_scan, use_cloud, noise,
                         seed)


def detect(scene, config=None, **kwargs):
    scan_frame, cloud_frame = frames(scene, **kwargs)
    return ObstacleDetector(config).detect(scan=scan_frame, cloud=cloud_frame)


@pytest.mark.parametrize("noise", [0.0, 0.01])
@pytest.mark.parametrize("where", [(3.0, 0.5), (2.0, -1.5), (-2.5, 1.0), (5.0, 0.0)])
def test_a_pillar_seen_by_the_lidar_alone_is_centred_within_5_cm(where, noise):
    pillar = Pillar(*where, radius=0.3)
    report = detect([pillar], use_cloud=False, noise=noise)
    [o] = report.obstacles
    assert o.plane == ObstaclePlane.VERTICAL
    assert math.hypot(o.center[0] - pillar.x, o.center[1] - pillar.y) < 0.05
    assert 0.28 <= min(o.semi_axes) and max(o.semi_axes) <= 0.38
    assert o.id == "" and o.velocity_source == 0 and not np.any(o.velocity)
    cov = np.asarray(o.position_covariance)
    assert cov.shape == (3, 3) and np.all(np.linalg.eigvalsh(cov) > 0)


@pytest.mark.parametrize("kind", ["quadruped", "biped"])
def test_a_pillar_seen_by_both_sensors_is_one_vertical_obstacle(kind):
    pillar = Pillar(3.0, 0.4, radius=0.3, height=1.2)
    report = detect([pillar], kind=kind, noise=0.005)
    [o] = report.obstacles
    assert o.plane == ObstaclePlane.VERTICAL
    assert math.hypot(o.center[0] - 3.0, o.center[1] - 0.4) < 0.05
    # Stands on the ground up to the highest return (the biped's sensor looks down 20 deg
    # and does not see the top: then the extent is what it saw, above its scan plane).
    assert o.center[2] == pytest.approx(0.5 * o.extent)
    assert 1.05 <= o.extent <= 1.25


@pytest.mark.parametrize("kind", ["quadruped", "biped"])
def test_a_walker_sized_cylinder(kind):
    walker = Pillar(2.0, -1.0, radius=0.2, height=1.7)
    report = detect([walker], kind=kind, noise=0.005)
    [o] = report.obstacles
    assert o.plane == ObstaclePlane.VERTICAL
    assert math.hypot(o.center[0] - 2.0, o.center[1] + 1.0) < 0.05
    assert 0.18 <= min(o.semi_axes) and max(o.semi_axes) <= 0.28
    # The whole true cross-section is inside the reported ellipse.
    ring = np.array([[2.0 + 0.2 * math.cos(t), -1.0 + 0.2 * math.sin(t)]
                     for t in np.linspace(0, 2 * math.pi, 36)])
    assert np.all(inside_vertical(o, ring, grow=0.03))


def test_a_wall_across_the_path_is_split_into_pieces_that_cover_its_face():
    wall = Box(2.5, 0.0, length=0.2, width=3.0, height=1.0)  # face at x = 2.4, y in [-1.5, 1.5]
    report = detect([wall], noise=0.005)
    pieces = vertical(report)
    assert not horizontal(report)
    assert len(pieces) >= 5
    for o in pieces:  # at most 0.5 m long, enclosing-ellipse growth and margin aside
        assert o.semi_axes[0] <= 0.25 * math.sqrt(2) + 0.03
    # Every point of the face the sensors see (|y| <= 1.2 m here) is inside some piece.
    face = np.column_stack([np.full(49, 2.4), np.linspace(-1.2, 1.2, 49)])
    covered = np.zeros(len(face), dtype=bool)
    for o in pieces:
        covered |= inside_vertical(o, face, grow=0.01)
    assert covered.all(), face[~covered]


def test_a_wall_beside_the_path_is_pieces_of_at_most_half_a_metre():
    wall = Box(3.25, 0.55, length=3.0, width=0.2, height=1.2)  # quadruped_wall: face y = 0.45
    report = detect([wall])
    pieces = vertical(report)
    assert len(pieces) >= 4 and not horizontal(report)
    for o in pieces:
        assert o.semi_axes[0] <= 0.25 * math.sqrt(2) + 0.03
        assert o.center[1] > 0.40  # on the face or behind it, not on the robot's side


@pytest.mark.parametrize("distance", [0.8, 1.5, 2.0, 3.0])
@pytest.mark.parametrize("base_z", [0.20, 0.28])
def test_a_bar_cut_by_the_lidar_plane_is_horizontal_never_vertical(distance, base_z):
    bar = Bar(distance, z=0.35, radius=0.05)  # underside 0.30 m, quadruped_bar_and_pillar
    scan_frame, cloud_frame = frames([bar], pose=Pose(z=base_z))
    lidar_z = base_z + default_mounts("quadruped")[LIDAR_FRAME].xyz[2]
    cut = np.abs(scan_frame.points[:, 0] - distance) < 0.1
    if 0.30 <= lidar_z <= 0.40:
        assert np.count_nonzero(cut) > 10  # the scan plane does cut the bar
    report = ObstacleDetector().detect(scan=scan_frame, cloud=cloud_frame)
    assert not vertical(report), [o.center for o in vertical(report)]
    [o] = horizontal(report)
    # Conservative and close: at most one row of the 3-D sensor (cloud_row_spacing) lower.
    underside = o.center[2] - o.semi_axes[1]
    lowest = 0.30 - 0.01 - distance * math.tan(DetectorConfig().cloud_row_spacing)
    assert lowest <= underside <= 0.30 + 0.002
    assert o.center[0] == pytest.approx(distance, abs=0.06)
    assert o.semi_axes[0] >= 0.05 and o.orientation == 0.0
    # the span the 3-D sensor sees along y at the bar (60 deg wide), or more with the LiDAR
    depth_x = default_mounts("quadruped")[DEPTH_FRAME].xyz[0]
    seen = 2.0 * (distance - depth_x) * math.tan(math.radians(30.0))
    assert o.extent > min(0.7, 0.9 * seen)


def test_a_bar_across_the_biped_s_path_is_horizontal():
    bar = Bar(1.6, z=0.95, radius=0.05)  # biped_low_bar: below the biped's scan plane
    report = detect([bar], kind="biped")
    assert not vertical(report)
    [o] = horizontal(report)
    assert 0.90 - 0.01 - 1.6 * math.tan(0.02) <= o.center[2] - o.semi_axes[1] <= 0.902


def test_a_bar_on_posts_is_a_bar_between_two_posts():
    scene = [Bar(2.0, z=0.4, radius=0.05, y0=-1.0, y1=1.0),
             Box(2.0, -1.0, 0.1, 0.1, 0.45), Box(2.0, 1.0, 0.1, 0.1, 0.45)]
    report = detect(scene)
    posts = vertical(report)
    assert len(posts) == 2
    assert sorted(round(o.center[1]) for o in posts) == [-1, 1]
    bars = horizontal(report)
    assert bars
    assert all(abs(o.center[1]) < 0.9 for o in bars)
    assert all(0.30 <= o.center[2] - o.semi_axes[1] <= 0.352 for o in bars)
    # No vertical obstacle on the path between the posts.
    assert all(abs(o.center[1]) - o.semi_axes[0] > 0.5 for o in posts)


def test_a_pillar_joined_to_a_bar_outside_the_cloud_s_view_stays_vertical():
    # The scan plane cuts the bar and, beyond the 3-D sensor's side of view, a pillar that
    # touches it: the pillar is not swallowed by the bar.
    scene = [Bar(2.0, z=0.35, radius=0.05, y0=-3.0, y1=3.0), Pillar(1.8, 1.8, 0.2)]
    report = detect(scene)
    [bar] = [o for o in horizontal(report) if abs(o.center[1]) < 1.0]
    assert bar.semi_axes[0] < 0.1
    pillar = [o for o in vertical(report) if math.hypot(o.center[0] - 1.8, o.center[1] - 1.8)
              < 0.05]
    assert len(pillar) == 1
    assert all(abs(o.center[1]) > 1.5 for o in vertical(report))


def test_something_only_the_lidar_sees_is_vertical():
    # A bar behind the robot: outside the 3-D sensor's view; the scan plane cuts it. Its
    # height is unknown, so it is reported as standing (safe; it is not on the path ahead).
    report = detect([Bar(-1.5, z=0.35, radius=0.05)])
    assert not horizontal(report)
    assert vertical(report)
    assert all(o.center[0] < -1.0 for o in report.obstacles)


def test_a_pillar_whose_foot_is_out_of_view_is_vertical():
    # 0.45 m ahead of the A1's level 3-D sensor, the foot of a pillar is below its view.
    report = detect([Pillar(0.75, 0.0, radius=0.1, height=1.0)], use_scan=False)
    assert report.obstacles and not horizontal(report)


@pytest.mark.parametrize("kind", ["quadruped", "biped"])
@pytest.mark.parametrize("pitch_error,roll_error", [(0.0, 0.0), (0.015, 0.0), (-0.015, 0.01)])
def test_ground_only_frames_give_no_obstacle_despite_pitch_noise(kind, pitch_error, roll_error):
    true = Pose(z=BASE_Z[kind], pitch=math.radians(3.0), roll=math.radians(-1.0))
    believed = Pose(z=BASE_Z[kind], pitch=true.pitch + pitch_error, roll=true.roll + roll_error)
    scan_frame, cloud_frame = frames([], kind=kind, pose=true, odom=believed, noise=0.01)
    if kind == "quadruped":
        assert len(scan_frame.points) > 0  # the pitched scan plane hits the ground
    report = ObstacleDetector().detect(scan=scan_frame, cloud=cloud_frame)
    assert report.obstacles == []
    assert report.ground > 0


def test_self_points_are_dropped():
    kind = "quadruped"
    mounts, history = default_mounts(kind), PoseHistory()
    history.add(STAMP, [1.0, 2.0, 0.28], [0.0, 0.0, 0.0, 1.0])
    depth = mounts[DEPTH_FRAME]
    # Returns from the robot's own front legs (base_link: x 0.15-0.24 m, y +-0.12 m, z -0.25
    # to -0.17 m), as the 3-D sensor sees them: in its own frame.
    legs_base = np.array([[0.15 + 0.01 * i, 0.12 * s, -0.25 + 0.02 * j]
                          for i in range(10) for s in (-1, 1) for j in range(5)])
    to_sensor = np.linalg.inv(depth.matrix())
    legs = legs_base @ to_sensor[:3, :3].T + to_sensor[:3, 3]
    frame = make_frame("cloud", STAMP, legs, depth.matrix(), history, default_self_box(kind))
    assert frame.self_points == len(legs) and frame.points.shape == (0, 3)
    report = ObstacleDetector().detect(cloud=frame)
    assert report.obstacles == []


def test_several_obstacles_and_the_nearest_first():
    scene = [Pillar(3.0, 0.5, 0.3), Pillar(2.0, -1.2, 0.2, 1.7), Pillar(4.5, -0.5, 0.25)]
    report = detect(scene, noise=0.005)
    assert len(report.obstacles) == 3
    d = [math.hypot(*o.center[:2]) for o in report.obstacles]
    assert d == sorted(d)
    config = DetectorConfig(max_obstacles=2)
    capped = detect(scene, config=config, noise=0.005)
    assert len(capped.obstacles) == 2 and capped.dropped_obstacles == 1


def test_a_moving_scan_is_deskewed_with_the_odometry_history():
    # The robot moves 1 m/s along x while a 360-beam scan takes 0.1 s.
    pillar = Pillar(3.0, 0.0, 0.3)
    lidar = default_mounts("quadruped")[LIDAR_FRAME]
    history = PoseHistory()
    for k in range(13):
        t = STAMP + 0.01 * k
        history.add(t, [t - STAMP, 0.0, 0.28], [0.0, 0.0, 0.0, 1.0])
    angle_min, inc = scan_angles(360)
    ranges = np.empty(360)
    for i in range(360):  # beam by beam from where the robot was
        beam = scan(Pose(x=0.1 * i / 360, z=0.28), lidar, [pillar])
        ranges[i] = beam[i]
    sp = scan_points(ranges, angle_min, inc, 0.05, 10.0, time_increment=0.1 / 360)
    frame = make_frame("scan", STAMP, sp.points, lidar.matrix(), history,
                       default_self_box("quadruped"), sp.beam_times, sp.beams, inc, 360)
    [o] = ObstacleDetector().detect(scan=frame).obstacles
    assert math.hypot(o.center[0] - 3.0, o.center[1]) < 0.05


def test_config_errors_name_the_parameter():
    with pytest.raises(ValueError, match="^cluster_tolerance"):
        DetectorConfig(cluster_tolerance=-1.0)
    with pytest.raises(ValueError, match="^voxel_size"):
        DetectorConfig(voxel_size=0.3, cluster_tolerance=0.2)
    with pytest.raises(ValueError, match="^tilt_noise"):
        DetectorConfig(tilt_noise=0.5)


def test_wall_pieces_stay_put_while_the_robot_moves_along_the_wall():
    # Longer than the sensors' range: the part seen moves with the robot.
    wall = Box(2.5, 0.0, length=0.2, width=30.0, height=1.0)  # face at x = 2.4
    before = vertical(detect([wall], pose=Pose(y=0.0)))
    after = vertical(detect([wall], pose=Pose(x=0.3, y=0.45)))
    inner = [o for o in after if abs(o.center[1] - 0.45) < 1.0]  # away from the view's edges
    assert len(inner) >= 3
    for o in inner:
        nearest = min(np.hypot(*(p.center[:2] - o.center[:2])) for p in before)
        assert nearest < 0.02, o.center


def test_only_a_wall_piece_s_open_ends_are_uncertain_along_the_wall():
    """Pieces cut at both ends report ~position_std along the wall; end pieces, whose centre
    moves as more of the wall comes into view, (max_piece_length / 4)^2 per open end (#19)."""
    wall = Box(2.5, 0.1, length=0.2, width=3.0, height=1.0)  # face x = 2.4, y -1.4 .. 1.6
    pieces = sorted(vertical(detect([wall])), key=lambda o: o.center[1])
    along = [math.sqrt(o.position_covariance[1, 1]) for o in pieces]
    across = [math.sqrt(o.position_covariance[0, 0]) for o in pieces]
    assert len(pieces) == 9, along  # cut at y = k * 0.354 m, k = -3 ... 4
    assert max(along[1:-1]) < 0.03 and max(across) < 0.03, (along, across)
    assert min(along[0], along[-1]) > 0.12, along


def test_wall_pieces_are_cut_where_they_were_when_the_fitted_axis_turns():
    """A bench's face seen partly (its returns' axis off by ~0.15 rad) is cut on the same odom
    lines as when the whole face is seen: its inner pieces keep their points (#19: cuts at
    multiples along the fitted axis moved by 1.2 m x the axis' error and swapped pieces)."""
    x = np.arange(0.9, 2.4, 0.02)
    face = np.column_stack([x, np.full_like(x, -1.18)])
    # returns on the bench's near end, lower down and set back (a partly seen seat)
    blob = np.column_stack([np.linspace(0.9, 1.3, 40), np.linspace(-1.18, -0.8, 40)])
    whole = split_pieces(face, 0.5)
    tilted = split_pieces(np.vstack([face, blob]), 0.5)
    angle = math.atan2(tilted[0].axis[1], tilted[0].axis[0])
    assert 0.05 < abs((angle + 0.5 * math.pi) % math.pi - 0.5 * math.pi) < 0.3, angle
    n = face.shape[0]
    sets = {tuple(p.index) for p in whole}
    inner = [tuple(i for i in p.index if i < n) for p in tilted]
    inner = [m for m in inner if m and min(face[list(m), 0]) > 1.3]  # away from the blob
    assert len(inner) >= 2
    for m in inner:
        assert m in sets, (face[list(m), 0].min(), face[list(m), 0].max())
