"""Multi-obstacle tracking: detections in, obstacles with velocities and covariances out.

Pure Python/numpy (no ROS); :mod:`safe_legged_c3bf.nodes.obstacle_tracker_node` wraps it.
The obstacle detector (range sensors in, detections out) lives beside it and is imported
from its own modules (:mod:`safe_legged_c3bf.perception.detector` and the modules it names),
wrapped by :mod:`safe_legged_c3bf.nodes.obstacle_detector_node`.
"""

from safe_legged_c3bf.perception.track import (
    Detection,
    ObstaclePlane,
    Track,
    TrackConfig,
    TrackedObstacle,
    TrackStatus,
)
from safe_legged_c3bf.perception.tracker import (
    MultiObstacleTracker,
    RejectionReason,
    TrackerConfig,
    UpdateReport,
    validate_detection,
)

__all__ = [
    "Detection",
    "MultiObstacleTracker",
    "ObstaclePlane",
    "RejectionReason",
    "Track",
    "TrackConfig",
    "TrackStatus",
    "TrackedObstacle",
    "TrackerConfig",
    "UpdateReport",
    "validate_detection",
]
