"""Seen through: a 2-D LiDAR scan clears the tracks whose place it sees empty (no ROS).

A confirmed track that stops getting detections coasts on its last velocity, and near the
moving robot it is kept up to ``keep_near_max_coast_time`` (5 s): an obstacle beside the
robot, out of the forward 3-D sensor's view, is not forgotten. When that velocity was a
phantom (the detector's cluster jumped from one frame to the next, session 18), the track
drives its ghost across the floor, through the robot: on random biped seed 5 with sensors a
0.63 m/s phantom coasted 4 s into the robot, which braked and backed out of nothing.

The LiDAR sees all around, in its plane. Where its beams pass right through a coasting
track's predicted place, nothing tall enough to cross that plane stands there: the track is
cleared (deleted), as a costmap's clearing observation source clears cells by ray tracing.
Only what the scan can vouch for is cleared:

* vertical tracks whose top (``center z + extent / 2`` at their last update, odom) reaches
  the scan plane there (within ``clear_height_tolerance``): a low bench the LiDAR passes over
  is never cleared;
* tracks not updated for ``clear_after`` s (a few detection periods: an obstacle being
  detected is never judged by the scan);
* when at least ``clear_min_beams`` readable beams cross the track's core (the circle of its
  smaller semi-axis about its predicted centre) and *every* one of them reaches beyond the
  core's far side by ``clear_margin``: a beam that drops out (NaN) says nothing, a beam that
  ends in or before the core (the obstacle, or something hiding it) keeps the track;
* after ``clear_scans`` such scans in a row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.perception.pose_history import PoseHistory, PoseLookup

__all__ = ["ClearingConfig", "ScanPlacer", "SeenFree", "seen_free", "seen_through"]


@dataclass(frozen=True)
class ClearingConfig:
    """How a scan clears tracks (the tracker's ``clear_*`` parameters, see module doc).

    Attributes:
        after: s without an update before a track may be cleared.
        scans: consecutive scans that must see through a track.
        min_beams: readable beams that must cross the track's core.
        margin: m each of them must reach beyond the core's far side.
        height_tolerance: m the track's top may be below the scan plane.
        min_core: m, smallest core radius used (a thin wall piece's).

    """

    after: float = 0.25
    scans: int = 2
    min_beams: int = 3
    margin: float = 0.1
    height_tolerance: float = 0.05
    min_core: float = 0.05


@dataclass(frozen=True)
class SeenFree:
    """What one scan saw free, in odom.

    Attributes:
        stamp: scan stamp (s).
        origin: (3,) LiDAR origin in odom (m).
        bearings: (n,) odom yaw of each beam (rad, in [-pi, pi]).
        reach: (n,) horizontal distance each beam saw free (m); NaN = no reading.
        climb: (n,) rise of each beam per metre of horizontal distance (tilted LiDAR).

    """

    stamp: float
    origin: np.ndarray
    bearings: np.ndarray
    reach: np.ndarray
    climb: np.ndarray


def seen_free(
    stamp: float, odom_from_lidar: np.ndarray, angle_min: float, angle_increment: float,
    ranges: np.ndarray, range_min: float, range_max: float,
) -> SeenFree:
    """The free space of a ``LaserScan`` whose frame is at ``odom_from_lidar`` (4 x 4).

    REP-117: ``+inf`` is no return within ``range_max`` (free up to it); NaN, ``-inf`` and
    readings outside [range_min, range_max] are unknown.
    """
    r = np.asarray(ranges, dtype=float).reshape(-1)
    free = np.where(np.isposinf(r), range_max, r)
    free = np.where((free >= range_min) & (free <= range_max), free, np.nan)
    angles = angle_min + angle_increment * np.arange(r.size)
    local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])
    d = np.asarray(odom_from_lidar, dtype=float)[:3, :3] @ local
    horizontal = np.hypot(d[0], d[1])
    flat = np.maximum(horizontal, 1e-9)
    return SeenFree(
        float(stamp), np.asarray(odom_from_lidar, dtype=float)[:3, 3].copy(),
        np.arctan2(d[1], d[0]), free * horizontal, d[2] / flat,
    )


class ScanPlacer:
    """Places scans in odom: the LiDAR's mount and a short history of /odom poses.

    Args:
        mount: (4, 4) base_link <- LiDAR (``SensorMount.matrix()``).
        history: s of poses kept; a scan older than that has no pose.
        max_extrapolation: s a scan may be newer than the newest pose.

    """

    def __init__(self, mount: np.ndarray, history: float = 1.0, max_extrapolation: float = 0.05):
        """A placer with no pose yet."""
        self.mount = np.asarray(mount, dtype=float).reshape(4, 4)
        self.poses = PoseHistory(history, max_extrapolation)

    def add_pose(self, t: float, position: np.ndarray, quaternion: np.ndarray) -> None:
        """The base pose at ``t`` (odom; quaternion x, y, z, w); an older clock starts anew."""
        newest = self.poses.newest
        if newest is not None and t < newest - self.poses.duration:
            self.poses.clear()
        self.poses.add(t, position, quaternion)

    def seen_free(
        self, stamp: float, angle_min: float, angle_increment: float, ranges: np.ndarray,
        range_min: float, range_max: float,
    ) -> SeenFree | None:
        """The scan's free space in odom; None when no pose places its stamp."""
        if self.poses.check(stamp) is not PoseLookup.OK:
            return None
        position, rotation = self.poses.pose_at(stamp)
        odom_from_base = np.eye(4)
        odom_from_base[:3, :3], odom_from_base[:3, 3] = rotation, position
        return seen_free(
            stamp, odom_from_base @ self.mount, angle_min, angle_increment, ranges, range_min,
            range_max,
        )


def seen_through(
    seen: SeenFree, center: np.ndarray, core: float, top: float, config: ClearingConfig
) -> bool:
    """True when ``seen`` shows empty a vertical obstacle's core.

    Args:
        seen: the scan's free space.
        center: (2,) x, y of the obstacle's predicted centre at ``seen.stamp`` (odom, m).
        core: radius of its core (m): its smaller semi-axis.
        top: height of its top (odom z, m) as last measured.
        config: the clearing thresholds.

    """
    offset = np.asarray(center, dtype=float)[:2] - seen.origin[:2]
    distance = float(math.hypot(offset[0], offset[1]))
    core = max(float(core), config.min_core)
    if distance <= core + config.margin:
        return False
    bearing = math.atan2(offset[1], offset[0])
    half = math.asin(core / distance)
    across = np.abs((seen.bearings - bearing + math.pi) % (2.0 * math.pi) - math.pi) <= half
    reach = seen.reach[across]
    readable = np.isfinite(reach)
    if int(readable.sum()) < config.min_beams:
        return False
    plane_z = seen.origin[2] + distance * float(np.mean(seen.climb[across]))
    if top < plane_z - config.height_tolerance:
        return False
    return bool(np.all(reach[readable] > distance + core + config.margin))
