"""Detector frames of a synthetic scene (:mod:`detector_scenes`) and helpers on reports,
shared by the detector tests."""

from __future__ import annotations

import math

import numpy as np
from detector_scenes import cloud, scan, scan_angles

from safe_legged_c3bf.interfaces.sensor_mounts import DEPTH_FRAME, LIDAR_FRAME, default_mounts
from safe_legged_c3bf.perception.pose_history import PoseHistory
from safe_legged_c3bf.perception.self_filter import default_self_box
from safe_legged_c3bf.perception.sensor_frame import make_frame
from safe_legged_c3bf.perception.sensor_points import scan_points
from safe_legged_c3bf.perception.track import ObstaclePlane


def sensor_frames(scene, kind, pose, odom, stamp, use_scan=True, use_cloud=True, noise=0.0,
                  seed=0):
    """Scan and cloud frames (None when not used) of ``scene`` seen from ``pose`` at ``stamp``
    (s) by robot ``kind``'s sensors; the detector believes the base is at ``odom``."""
    mounts = default_mounts(kind)
    history = PoseHistory()
    history.add(stamp, [odom.x, odom.y, odom.z], odom.quaternion())
    box = default_self_box(kind)
    scan_frame = cloud_frame = None
    if use_scan:
        lidar = mounts[LIDAR_FRAME]
        angle_min, inc = scan_angles(360)
        sp = scan_points(scan(pose, lidar, scene, noise=noise, seed=seed), angle_min, inc,
                         0.05, 10.0)
        scan_frame = make_frame("scan", stamp, sp.points, lidar.matrix(), history, box,
                                beams=sp.beams, angle_increment=inc, beam_count=sp.beam_count)
    if use_cloud:
        depth = mounts[DEPTH_FRAME]
        pts = cloud(pose, depth, scene, noise=noise, seed=seed + 1).reshape(-1, 3)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        cloud_frame = make_frame("cloud", stamp, pts, depth.matrix(), history, box)
    return scan_frame, cloud_frame


def vertical(report):
    return [o for o in report.obstacles if o.plane == ObstaclePlane.VERTICAL]


def horizontal(report):
    return [o for o in report.obstacles if o.plane == ObstaclePlane.HORIZONTAL]


def inside_vertical(o, xy, grow=0.0):
    """True for the points (n, 2) inside the x-y ellipse of a vertical obstacle."""
    c, s = math.cos(o.orientation), math.sin(o.orientation)
    d = np.asarray(xy) - o.center[:2]
    u, v = d @ [c, s], d @ [-s, c]
    a, b = o.semi_axes[0] + grow, o.semi_axes[1] + grow
    return (u / a) ** 2 + (v / b) ** 2 <= 1.0
