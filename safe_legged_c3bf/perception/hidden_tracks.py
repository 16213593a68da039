"""Unseen tracks whose place a detection fills: their ellipses do not grow (no ROS).

A confirmed track that gets no detection coasts, and from ``coast_growth_after`` its
published semi-axes grow by ``coast_growth`` (m/s): the ellipse covers where an unseen
obstacle may have gone. Near the moving robot such a track is kept up to 5 s, so it may
grow by 1.5 m.

Often the track is not unseen at all: the detector cuts an elongated obstacle into other
pieces when it is seen from another side, and one piece's track stops getting detections
while its neighbour's detection now covers both. On random A1 seed 37 with sensors such a
piece of a pillar beside the path grew from 0.37 to 1.49 m in 4 s, covered the robot, and
the filter spent 3 s escaping from inside it.

Two solid obstacles do not overlap: when a coasting vertical track's predicted centre lies
inside a vertical detection of the current batch, its obstacle is in that detection (a piece
of it, or a walker in one cluster with a pillar). It has gone nowhere unseen, and it stops
growing until the place is no longer covered. Nothing is deleted: the track keeps its own
ellipse and is deleted by the ordinary coast rules.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from safe_legged_c3bf.perception.track import Detection, ObstaclePlane

__all__ = ["inside_vertical_detections"]


def inside_vertical_detections(
    points_xy: np.ndarray, detections: Sequence[Detection]
) -> np.ndarray:
    """Which points (n, 2) (odom x, y, m) lie inside some vertical detection's ellipse.

    The ellipse is the detection's in x-y: centre, semi-axes ``(a, b)`` (m) and orientation
    of ``a`` from odom +x (rad). Points on the boundary count as inside. Returns (n,) bool.
    """
    points = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    inside = np.zeros(len(points), dtype=bool)
    for det in detections:
        if ObstaclePlane(det.plane) is not ObstaclePlane.VERTICAL:
            continue
        a, b = (float(s) for s in det.semi_axes)
        cos, sin = np.cos(det.orientation), np.sin(det.orientation)
        rel = points - np.asarray(det.center, dtype=float)[:2]
        along = rel[:, 0] * cos + rel[:, 1] * sin
        across = -rel[:, 0] * sin + rel[:, 1] * cos
        inside |= (along / a) ** 2 + (across / b) ** 2 <= 1.0
    return inside
