"""Standing or floating: which obstacle points reach down to the ground (no ROS).

Two tests tell a bar the robot may duck under from something standing on the ground:

* **Columns** (:func:`grounded_mask`). The x-y plane is cut into cells of ``column_cell``
  m; a point's column is its cell and the 8 around it. A point is *grounded* when the lowest
  candidate point of its column is below the touch threshold (the ground threshold plus
  ``ground_touch_height``, :meth:`DetectorConfig.touch_threshold`). A pillar's top is grounded
  through its foot, the posts under a bar are grounded but the bar between them is not.
* **Free-space rays** (:func:`rays_beneath`). A point that is not grounded may still belong
  to something standing whose foot the sensors did not see (out of the 3-D sensor's field of
  view, or seen only in the 2-D scan plane). Only positive evidence makes it overhead: rays of
  the 3-D sensor that pass *beneath* the floating cluster, at least ``free_space_margin``
  below its underside, and end beyond it (they hit the ground or something farther). The
  rays beneath a pillar whose foot is out of view do not exist (the foot is where the view
  ends), and rays beneath something behind a low box end on the box.
* **What the cloud vouches for** (:func:`covered_by_cloud`). A floating cluster may hold
  scan returns outside the 3-D sensor's view (the LiDAR sees a bar beyond the cloud's
  sides). They stay with the bar when they lie on its line; anything else joined to it out
  there (a pillar the bar passes) is something only the LiDAR sees, and stays VERTICAL.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.perception.detector_config import DetectorConfig

__all__ = ["FreeSpace", "covered_by_cloud", "grounded_mask", "rays_beneath", "underside"]


def _column_min(points: np.ndarray, cell: float) -> np.ndarray:
    """(n,) lowest z (m) among the points in each point's 3 x 3 column of x-y cells."""
    ij = np.floor(points[:, :2] / cell).astype(np.int64)
    ij -= ij.min(axis=0) - 1  # every neighbour index is >= 0
    stride = int(ij[:, 1].max()) + 2
    key = ij[:, 0] * stride + ij[:, 1]
    cells, inverse = np.unique(key, return_inverse=True)
    cell_min = np.full(cells.size, np.inf)
    np.minimum.at(cell_min, inverse.reshape(-1), points[:, 2])
    lowest = np.full(points.shape[0], np.inf)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):  # nine lookups, each over all points at once
            neighbour = key + di * stride + dj
            pos = np.minimum(np.searchsorted(cells, neighbour), cells.size - 1)
            hit = cells[pos] == neighbour
            lowest = np.where(hit, np.minimum(lowest, cell_min[pos]), lowest)
    return lowest


def grounded_mask(points: np.ndarray, touch: np.ndarray, cell: float) -> np.ndarray:
    """(n,) True where a point's column reaches down below its touch height.

    Args:
        points: (n, 3) candidate points in odom (m), ground removed.
        touch: (n,) touch threshold of each point (m, odom z).
        cell: edge of the x-y cells (m).

    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    return _column_min(p, cell) <= np.asarray(touch, dtype=float)


@dataclass(frozen=True)
class FreeSpace:
    """What the 3-D sensor's rays say about the space beneath a floating cluster.

    Attributes:
        rays: rays passing at least ``free_space_margin`` beneath the cluster and ending
            beyond it (the evidence that it floats).
        clear_height: highest height (m, odom) at which a ray was seen passing beneath the
            cluster and beyond it; NaN when none was. The true underside lies between this
            and the cluster's lowest return (see :func:`underside`).

    """

    rays: int
    clear_height: float


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def rays_beneath(
    cluster: np.ndarray, origin: np.ndarray, ends: np.ndarray, config: DetectorConfig
) -> FreeSpace:
    """The rays from ``origin`` to ``ends`` that pass beneath ``cluster`` and beyond it.

    A ray passes beneath when its azimuth about the origin lies within the cluster's azimuth
    span and within ``free_space_azimuth`` of a cluster point's, it ends more than
    ``free_space_margin`` farther (horizontally) than that point, and at that point's
    distance it is below the cluster's lowest point; it counts as evidence when it is more
    than ``free_space_margin`` below.

    Args:
        cluster: (k, 3) points of one floating cluster (odom, m).
        origin: (3,) the 3-D sensor's origin at the cloud's stamp (odom, m).
        ends: (m, 3) every return of that cloud outside the self box, ground included
            (odom, m).
        config: the margins and the azimuth tolerance.

    """
    c = np.asarray(cluster, dtype=float).reshape(-1, 3)
    e = np.asarray(ends, dtype=float).reshape(-1, 3)
    o = np.asarray(origin, dtype=float).reshape(3)
    if c.shape[0] == 0 or e.shape[0] == 0:
        return FreeSpace(0, math.nan)
    rel = c[:, :2] - o[:2]
    azimuth = np.arctan2(rel[:, 1], rel[:, 0])
    ref = np.arctan2(np.sin(azimuth).mean(), np.cos(azimuth).mean())
    angle = _wrap(azimuth - ref)
    order = np.argsort(angle)
    angle, dist = angle[order], np.hypot(rel[order, 0], rel[order, 1])

    ray = e[:, :2] - o[:2]
    length = np.hypot(ray[:, 0], ray[:, 1])
    ray_angle = _wrap(np.arctan2(ray[:, 1], ray[:, 0]) - ref)
    tol = config.free_space_azimuth
    # Only rays within the cluster's own azimuth span: a ray just beside a pillar passes
    # beneath the level of its top, but it is not beneath the pillar.
    near = (ray_angle >= angle[0]) & (ray_angle <= angle[-1]) & (length > 0.0)
    ray_angle, length, end_z = ray_angle[near], length[near], e[near, 2]
    right = np.clip(np.searchsorted(angle, ray_angle), 0, angle.size - 1)
    left = np.clip(right - 1, 0, angle.size - 1)
    pick = np.where(
        np.abs(angle[left] - ray_angle) <= np.abs(angle[right] - ray_angle), left, right
    )
    d = dist[pick]
    height = o[2] + (end_z - o[2]) * d / length  # the ray's height at the point's distance
    margin = config.free_space_margin
    bottom = float(c[:, 2].min())
    beneath = (np.abs(angle[pick] - ray_angle) < tol) & (length > d + margin) & (height < bottom)
    evidence = beneath & (height < bottom - margin)
    clear = float(height[beneath].max()) if np.any(beneath) else math.nan
    return FreeSpace(int(np.count_nonzero(evidence)), clear)


def underside(
    cluster: np.ndarray, origin: np.ndarray, free: FreeSpace, config: DetectorConfig
) -> float:
    """Conservative underside (m, odom z) of a floating cluster seen from ``origin``.

    The sensor's rows are ``cloud_row_spacing`` apart: the underside may lie up to one row
    below the lowest return, ``d * tan(cloud_row_spacing)`` at its horizontal distance ``d``.
    Rays that hit nothing are not in the cloud, so the highest ray seen passing beneath
    (``free.clear_height``) is often several rows lower; it is a floor (the space below it is
    known to be free), never the answer on its own.
    """
    c = np.asarray(cluster, dtype=float).reshape(-1, 3)
    low = int(np.argmin(c[:, 2]))
    d = float(np.hypot(*(c[low, :2] - np.asarray(origin, dtype=float)[:2])))
    estimate = float(c[low, 2]) - d * math.tan(config.cloud_row_spacing)
    return max(estimate, free.clear_height) if math.isfinite(free.clear_height) else estimate


def covered_by_cloud(
    points: np.ndarray, from_cloud: np.ndarray, origin: np.ndarray, tolerance: float
) -> np.ndarray:
    """(k,) True for the members of a floating cluster its 3-D sensor evidence covers.

    Cloud returns are covered, and so are scan returns within the azimuth span (about the
    cloud's ``origin``) of the cluster's cloud returns. A scan return outside that span is
    covered when it lies within ``tolerance`` (m, x-y) of the line through the scan returns
    inside the span (or, without two of them, through the cloud returns): the rest of a bar
    seen only in the scan plane.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    cloud = np.asarray(from_cloud, dtype=bool)
    covered = cloud.copy()
    if covered.all() or not covered.any():
        return covered
    rel = p[:, :2] - np.asarray(origin, dtype=float)[:2]
    azimuth = np.arctan2(rel[:, 1], rel[:, 0])
    ref = np.arctan2(np.sin(azimuth[cloud]).mean(), np.cos(azimuth[cloud]).mean())
    angle = _wrap(azimuth - ref)
    inside = (angle >= angle[cloud].min()) & (angle <= angle[cloud].max())
    covered |= inside
    reference = p[inside & ~cloud] if np.count_nonzero(inside & ~cloud) >= 2 else p[cloud]
    xy = reference[:, :2]
    mean = xy.mean(axis=0)
    if xy.shape[0] >= 2:
        _, vectors = np.linalg.eigh(np.cov((xy - mean).T))
        normal = vectors[:, 0]  # across the line (the smaller spread)
    else:
        normal = np.array([1.0, 0.0])  # a bar along odom y
    on_line = np.abs((p[:, :2] - mean) @ normal) <= tolerance
    return covered | (~inside & on_line)
