"""Ground removal and the candidate points of obstacles (no ROS).

The ground is the plane z = 0 of odom (the simulator's floor; REP-105 odom is gravity-aligned).
Points reach odom through the full 3-D base pose from ``/odom`` (roll and pitch included), so
a body that pitches while it trots does not tilt the ground seen by its sensors. What remains
is the error of that pose: a pitch or roll error of ``tilt_noise`` rad lifts or sinks a ground
return ``d`` m away by about ``d * tan(tilt_noise)``. The ground threshold therefore grows
with the horizontal distance from the sensor: a point is ground below
``ground_height + d * tan(tilt_noise)`` (:meth:`DetectorConfig.ground_threshold`), which
keeps the far ground out of the obstacles at the price of seeing low obstacles only nearer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.perception.detector_config import DetectorConfig

__all__ = ["HeightSplit", "split_by_height"]


@dataclass(frozen=True)
class HeightSplit:
    """Which points are ground and which may belong to an obstacle.

    Attributes:
        distance: (n,) horizontal distance of each point from its sensor (m).
        ground: (n,) True for ground returns.
        candidate: (n,) True for points that may be obstacles: above the ground threshold,
            not above ``max_height`` and within ``max_range`` of their sensor.

    """

    distance: np.ndarray
    ground: np.ndarray
    candidate: np.ndarray


def split_by_height(
    points: np.ndarray, origins: np.ndarray, config: DetectorConfig
) -> HeightSplit:
    """Ground and candidate masks of ``points`` (n, 3) seen from ``origins`` (n, 3), odom, m."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    o = np.broadcast_to(np.asarray(origins, dtype=float), p.shape)
    distance = np.hypot(p[:, 0] - o[:, 0], p[:, 1] - o[:, 1])
    ground = p[:, 2] < config.ground_threshold(distance)
    candidate = ~ground & (p[:, 2] <= config.max_height) & (distance <= config.max_range)
    return HeightSplit(distance, ground, candidate)
