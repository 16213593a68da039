"""The obstacle detector node's parameters: its own, then the detector's (no ROS).

The node declares them flat: the fields of :class:`ObstacleDetectorParams` and of
:class:`~safe_legged_c3bf.perception.detector_config.DetectorConfig`
(``config/obstacle_detector.yaml`` lists them with the same defaults). The robot kind, the
sensors used, the frames and the mounts are fixed at start-up; a detector field changes live.

Mounts and the self-filter box default to the robot kind's (``interfaces/sensor_mounts.py``,
``perception/self_filter.py``): a vector of three NaN means "the robot kind's value"; three
numbers replace it (a real robot's sensors, measured on the robot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from safe_legged_c3bf.interfaces.sensor_mounts import (
    DEPTH_FRAME,
    LIDAR_FRAME,
    SensorMount,
    resolve_mount,
)
from safe_legged_c3bf.interfaces.typed_params import (
    FINITE_OR_NAN,
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
from safe_legged_c3bf.perception.detector_config import DetectorConfig
from safe_legged_c3bf.perception.self_filter import SelfBox, resolve_self_box

__all__ = ["ObstacleDetectorParams"]

_UNSET = (math.nan, math.nan, math.nan)
_VECTOR = vector(3, FINITE_OR_NAN)
#: The fields that are three NaN (the robot kind's value) or three finite numbers.
_OVERRIDES = (
    "lidar_xyz", "lidar_rpy", "cloud_xyz", "cloud_rpy", "self_box_lower", "self_box_upper"
)


def _mount_field(what: str, unit: str, sensor: str) -> object:
    return param(
        _UNSET, unit, f"{what} of the {sensor} in base_link; NaN NaN NaN = the robot kind's "
        "mount (interfaces/sensor_mounts.py)", _VECTOR, fixed=True,
    )


@dataclass(frozen=True)
class ObstacleDetectorParams(TypedParams):
    """Obstacle detector node parameters; ``detector``: the detector's (nested)."""

    robot_kind: str = param(
        "quadruped", "-", "robot whose sensor mounts and footprint box are the defaults",
        one_of("quadruped", "biped"), fixed=True,
    )
    sensors: str = param(
        "both", "-", "which sensors to use: 'both' (publish at the scan rate, fusing the "
        "latest cloud), 'scan' (a robot with a 2-D LiDAR only) or 'cloud' (publish at the "
        "cloud rate)", one_of("both", "scan", "cloud"), fixed=True,
    )
    odom_frame: str = param(
        "odom", "-", "frame of /odom's pose and of the detections published", NON_EMPTY,
        fixed=True,
    )
    base_frame: str = param(
        "base_link", "-", "child frame of /odom (the robot's base)", NON_EMPTY, fixed=True
    )
    lidar_frame: str = param(
        LIDAR_FRAME, "-", "frame_id every /scan must carry", NON_EMPTY, fixed=True
    )
    cloud_frame: str = param(
        DEPTH_FRAME, "-", "frame_id every /points must carry", NON_EMPTY, fixed=True
    )
    lidar_xyz: tuple[float, float, float] = _mount_field("position", "m", "2-D LiDAR")
    lidar_rpy: tuple[float, float, float] = _mount_field("roll, pitch, yaw", "rad", "2-D LiDAR")
    cloud_xyz: tuple[float, float, float] = _mount_field("position", "m", "3-D sensor")
    cloud_rpy: tuple[float, float, float] = _mount_field("roll, pitch, yaw", "rad", "3-D sensor")
    self_box_lower: tuple[float, float, float] = param(
        _UNSET, "m", "lowest corner (x, y, z in base_link) of the robot's footprint box whose "
        "returns are dropped; NaN NaN NaN = the robot kind's box", _VECTOR, fixed=True,
    )
    self_box_upper: tuple[float, float, float] = param(
        _UNSET, "m", "highest corner of the footprint box; NaN NaN NaN = the robot kind's",
        _VECTOR, fixed=True,
    )
    max_future_stamp: float = param(
        0.1, "s", "how far a message stamp may be ahead of the node's clock; later stamps are "
        "rejected (a publisher not on sim time)", NON_NEGATIVE,
    )
    max_sensor_age: float = param(
        0.5, "s", "a scan or cloud whose stamp is older than this on arrival is rejected "
        "(stale); so is an /odom message", POSITIVE,
    )
    cloud_max_age: float = param(
        0.2, "s", "with sensors 'both', the cloud is fused with a scan when their stamps are "
        "at most this far apart; otherwise the scan is used alone", POSITIVE,
    )
    pose_history: float = param(
        1.0, "s", "odometry poses kept to place sensor stamps; older stamps have no pose",
        POSITIVE, fixed=True,
    )
    max_pose_extrapolation: float = param(
        0.05, "s", "a sensor stamp up to this much after the newest /odom gets the newest "
        "pose; later ones wait for no odometry and are dropped (after_odom)", NON_NEGATIVE,
    )
    max_message_bytes: int = param(
        4194304, "bytes", "/scan and /points messages larger than this (serialized) are "
        "rejected before decoding", at_least(1),
    )
    diagnostics_period: float = param(
        1.0, "s", "period of /diagnostics (sim time)", POSITIVE, fixed=True
    )
    detector: DetectorConfig = group(DetectorConfig)

    def __post_init__(self) -> None:
        """Validate the parameters (raises ``ValueError`` naming the bad one)."""
        self.validate()

    def check_together(self) -> None:
        """Each mount or box vector is all NaN (the default) or all finite."""
        for name in _OVERRIDES:
            value = getattr(self, name)
            nans = sum(math.isnan(v) for v in value)
            if 0 < nans < 3:
                raise ValueError(
                    f"{name}: must be three numbers or three NaN (the robot kind's), got "
                    f"{list(value)!r}"
                )
        self.self_box()  # the box resolved from the kind and the overrides must be valid

    def mounts(self) -> tuple[SensorMount, SensorMount]:
        """The LiDAR's and the 3-D sensor's mounts: the robot kind's, with the overrides."""
        return (
            resolve_mount(
                self.robot_kind, LIDAR_FRAME, self.lidar_frame, self.lidar_xyz, self.lidar_rpy
            ),
            resolve_mount(
                self.robot_kind, DEPTH_FRAME, self.cloud_frame, self.cloud_xyz, self.cloud_rpy
            ),
        )

    def self_box(self) -> SelfBox:
        """The footprint box: the robot kind's, with the overrides (ValueError if invalid)."""
        try:
            return resolve_self_box(self.robot_kind, self.self_box_lower, self.self_box_upper)
        except ValueError as err:
            raise ValueError(f"self_box_lower: {err}") from None
