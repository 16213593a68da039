"""One sensor message as points in odom, self-filtered (no ROS, no tf2).

sensor -> base_link is the sensor's mount (static, ``interfaces/sensor_mounts.py`` or the
node's overrides); base_link -> odom is the base pose from the odometry history at the
message's stamp (:class:`~safe_legged_c3bf.perception.pose_history.PoseHistory`). A scan
whose beams carry their own times (``time_increment``) gets one pose per beam, so a scan
taken while the robot moves is not smeared. Points inside the robot's footprint box are
dropped in base_link, before they reach odom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.perception.pose_history import PoseHistory, PoseLookup
from safe_legged_c3bf.perception.self_filter import SelfBox, outside_self_box
from safe_legged_c3bf.perception.sensor_points import SensorInputError, to_parent

__all__ = ["SensorFrame", "make_frame"]


@dataclass(frozen=True)
class SensorFrame:
    """Returns of one sensor message in odom.

    Attributes:
        kind: 'scan' (2-D LiDAR) or 'cloud' (3-D sensor).
        stamp: the message's stamp (s, sim time).
        points: (n, 3) returns outside the self box, in odom (m).
        origins: (n, 3) the sensor's origin in odom when each was measured (m).
        origin: (3,) the sensor's origin at ``stamp`` (odom, m).
        self_points: how many returns the self-filter dropped.
        beams: (n,) beam index of each return of a scan; -1 for a cloud's points.
        angle_increment: angle between a scan's beams (rad); 0 for a cloud.
        beam_count: beams in the scan; 0 for a cloud.

    """

    kind: str
    stamp: float
    points: np.ndarray
    origins: np.ndarray
    origin: np.ndarray
    self_points: int = 0
    beams: np.ndarray | None = None
    angle_increment: float = 0.0
    beam_count: int = 0

    def beam_index(self) -> np.ndarray:
        """(n,) beam index of each point, -1 where there is none (a cloud)."""
        if self.beams is None:
            return np.full(self.points.shape[0], -1, dtype=np.int64)
        return np.asarray(self.beams, dtype=np.int64)

    @property
    def is_cloud(self) -> bool:
        """True for a 3-D sensor's frame."""
        return self.kind == "cloud"


def make_frame(
    kind: str,
    stamp: float,
    points_sensor: np.ndarray,
    mount: np.ndarray,
    poses: PoseHistory,
    self_box: SelfBox,
    beam_times: np.ndarray | None = None,
    beams: np.ndarray | None = None,
    angle_increment: float = 0.0,
    beam_count: int = 0,
) -> SensorFrame:
    """Points of one message in odom.

    Args:
        kind: 'scan' or 'cloud'.
        stamp: the message's stamp (s).
        points_sensor: (n, 3) returns in the sensor frame (m).
        mount: (4, 4) transform base_link <- sensor (``SensorMount.matrix()``).
        poses: the odometry history.
        self_box: the robot's footprint box in base_link.
        beam_times: (n,) time of each return after ``stamp`` (s); None: all at ``stamp``.
        beams: a scan's beam index of each return (n,); None for a cloud.
        angle_increment: angle between a scan's beams (rad).
        beam_count: number of beams in the scan.

    Raises:
        SensorInputError: the history has no pose for the stamp (or the last beam's time);
            the reason is the :class:`PoseLookup` value ('no_odom', 'before_odom',
            'after_odom').

    """
    p = np.asarray(points_sensor, dtype=float).reshape(-1, 3)
    times = np.zeros(p.shape[0]) if beam_times is None else np.asarray(beam_times, float)
    last = float(times.max()) if times.size else 0.0
    for t in (stamp, stamp + last):
        verdict = poses.check(t)
        if verdict is not PoseLookup.OK:
            raise SensorInputError(verdict.value, f"no odometry pose at t = {t:.3f} s")
    base = to_parent(p, mount[:3, :3], mount[:3, 3])
    keep = outside_self_box(base, self_box)
    base, times = base[keep], times[keep]
    position, rotation = poses.pose_at(stamp)
    origin = rotation @ mount[:3, 3] + position
    if times.size and float(np.ptp(times)) > 0.0:
        positions, rotations = poses.interpolate(stamp + times)
        points = to_parent(base, rotations, positions)
        origins = np.einsum("nij,j->ni", rotations, mount[:3, 3]) + positions
    else:
        points = to_parent(base, rotation, position)
        origins = np.broadcast_to(origin, points.shape).copy()
    kept_beams = None if beams is None else np.asarray(beams, dtype=np.int64)[keep]
    return SensorFrame(
        kind, float(stamp), points, origins, origin, int(np.count_nonzero(~keep)),
        kept_beams, float(angle_increment), int(beam_count),
    )
