"""The obstacle tracker node's parameters: its own, then the tracker's and the tracks' (no ROS).

The node declares them flat: the fields of :class:`ObstacleTrackerParams`, of
:class:`~safe_legged_c3bf.perception.TrackerConfig` and of
:class:`~safe_legged_c3bf.perception.TrackConfig` (``config/obstacle_tracker.yaml`` lists them
with the same defaults). Changing a tracker or track field at run time restarts tracking;
``diagnostics_period`` is fixed at start-up.
"""

from __future__ import annotations

from dataclasses import dataclass

from safe_legged_c3bf.interfaces.typed_params import (
    FLAG,
    NON_NEGATIVE,
    POSITIVE,
    TypedParams,
    at_least,
    group,
    param,
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
        262144, "bytes", "detection messages larger than this (serialized) are rejected "
        "before decoding", at_least(1),
    )
    tracker: TrackerConfig = group(TrackerConfig)
