"""The obstacle tracker node's parameters: its own, then the tracker's and the tracks' (no ROS).

The node declares them flat: the fields of :class:`ObstacleTrackerParams`, of
:class:`~safe_legged_c3bf.perception.TrackerConfig` and of
:class:`~safe_legged_c3bf.perception.TrackConfig` (``config/obstacle_tracker.yaml`` lists them
with the same defaults). Changing a tracker or track field at run time restarts tracking;
``diagnostics_period`` is fixed at start-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from safe_legged_c3bf.interfaces.sensor_mounts import LIDAR_FRAME, SensorMount, resolve_mount
from safe_legged_c3bf.interfaces.typed_params import (
    FINITE_OR_NAN,
    FLAG,
    NON_EMPTY,
    NON_NEGATIVE,
    POSITIVE,
    TypedParams,
    at_least,
    group,
    one_of,
    param,
    vector,
)
from safe_legged_c3bf.perception.tracker import TrackerConfig


@dataclass(frozen=True)
class ObstacleTrackerParams(TypedParams):
    """Obstacle tracker node parameters; ``tracker``: the tracker configuration (nested)."""

    rate: float = param(30.0, "Hz", "publish rate of /obstacles (sim time)", POSITIVE)
    marker_rate: float = param(
        10.0, "Hz", "publish rate of /obstacles/markers (sim time); 0 disables markers",
        NON_NEGATIVE,
    )
    marker_inflation: float = param(
        0.15, "m", "added to the largest semi-axis for the inflated-circle marker", NON_NEGATIVE
    )
    detections_timeout: float = param(
        0.5, "s", "sim time without detections before /obstacles stops; also the oldest "
        "accepted stamp of a detection or /odom message", POSITIVE,
    )
    diagnostics_period: float = param(
        1.0, "s", "period of /diagnostics (sim time)", POSITIVE, fixed=True
    )
    publish_unestimated_velocity: bool = param(
        False, "-", "publish the raw velocity of tracks whose velocity is not yet estimated "
        "(velocity_source UNKNOWN) instead of zero (flag)", FLAG,
    )
    max_future_stamp: float = param(
        0.1, "s", "how far a message stamp may be ahead of the node's clock; later stamps are "
        "rejected (a publisher not on sim time)", NON_NEGATIVE,
    )
    max_message_bytes: int = param(
        262144, "bytes", "detection (and, with scan_clearing, /scan) messages larger than this "
        "(serialized) are rejected before decoding", at_least(1),
    )
    robot_kind: str = param(
        "quadruped", "-", "robot whose 2-D LiDAR mount is the default (scan_clearing)",
        one_of("quadruped", "biped"), fixed=True,
    )
    lidar_frame: str = param(
        LIDAR_FRAME, "-", "frame_id every /scan must carry (scan_clearing)", NON_EMPTY,
        fixed=True,
    )
    lidar_xyz: tuple[float, float, float] = param(
        (math.nan,) * 3, "m", "position of the 2-D LiDAR in base_link; NaN NaN NaN = the "
        "robot kind's mount (interfaces/sensor_mounts.py)", vector(3, FINITE_OR_NAN),
        fixed=True,
    )
    lidar_rpy: tuple[float, float, float] = param(
        (math.nan,) * 3, "rad", "roll, pitch, yaw of the 2-D LiDAR in base_link; NaN NaN NaN "
        "= the robot kind's", vector(3, FINITE_OR_NAN), fixed=True,
    )
    tracker: TrackerConfig = group(TrackerConfig)

    def check_together(self) -> None:
        """Each LiDAR mount vector is all NaN (the default) or all finite."""
        for name in ("lidar_xyz", "lidar_rpy"):
            nans = sum(math.isnan(v) for v in getattr(self, name))
            if 0 < nans < 3:
                raise ValueError(
                    f"{name}: must be three numbers or three NaN (the robot kind's), got "
                    f"{list(getattr(self, name))!r}"
                )

    def lidar_mount(self) -> SensorMount:
        """The 2-D LiDAR's mount: the robot kind's, with the overrides."""
        return resolve_mount(
            self.robot_kind, LIDAR_FRAME, self.lidar_frame, self.lidar_xyz, self.lidar_rpy
        )
