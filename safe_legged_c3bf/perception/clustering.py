"""Euclidean clustering of 3-D points with scipy (no ROS, no per-point Python loops).

Points are first thinned to one centroid per 3-D voxel (dense returns close to a sensor
would otherwise make the neighbour pairs grow with the square of the point count); voxels
closer than the tolerance are linked (``cKDTree.query_pairs``, in 3-D, or on x-y alone for
vertical obstacles, which are extruded along z so that what stands above the same ground is
one obstacle), extra links may be given (:func:`scan_links`), and the clusters are the
connected components of that graph (``scipy.sparse.csgraph.connected_components``). Every
point takes the label of its voxel.

:func:`scan_links` joins consecutive returns of a 2-D scan that lie on one surface even when
they are farther apart than the tolerance: a wall seen at a grazing angle is sampled sparsely
along its length (0.6 m between beams 4 m away at 6 degrees, for 1 degree beams). Two
neighbouring beams are joined when the distance between their returns is below what a
surface seen at ``incidence`` rad would give (the adaptive breakpoint rule of 2-D LiDAR
segmentation): ``r_min * sin(dtheta) / sin(incidence - dtheta)``.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

__all__ = ["cluster_labels", "connected_labels", "scan_links", "voxel_centroids"]


def voxel_centroids(points: np.ndarray, size: float) -> tuple[np.ndarray, np.ndarray]:
    """Centroids (v, 3) of the occupied voxels of edge ``size`` (m) and each point's voxel (n,)."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    cells = np.floor(p / size).astype(np.int64)
    cells -= cells.min(axis=0)
    span = cells.max(axis=0) + 1
    if float(np.prod(span.astype(float))) < 2.0**62:
        key = (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]
        _, inverse = np.unique(key, return_inverse=True)
    else:  # absurdly spread points: compare whole rows instead of one integer key
        _, inverse = np.unique(cells, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    counts = np.bincount(inverse).astype(float)
    centroids = np.column_stack(
        [np.bincount(inverse, weights=p[:, k]) / counts for k in range(3)]
    )
    return centroids, inverse


def connected_labels(
    points: np.ndarray, tolerance: float, links: np.ndarray | None = None
) -> np.ndarray:
    """(n,) component label of each point (n, k); closer than ``tolerance`` (m) is linked.

    The index pairs ``links`` (m, 2) are linked too.
    """
    p = np.asarray(points, dtype=float)
    n = p.shape[0]
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    pairs = cKDTree(p).query_pairs(tolerance, output_type="ndarray")
    if links is not None and len(links):
        pairs = np.vstack([pairs.reshape(-1, 2), np.asarray(links, dtype=np.int64)])
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return labels.astype(np.int64)


def scan_links(
    beams: np.ndarray,
    points: np.ndarray,
    origins: np.ndarray,
    angle_increment: float,
    beam_count: int,
    incidence: float,
) -> np.ndarray:
    """Index pairs (m, 2) of consecutive scan returns on one surface (module doc).

    Args:
        beams: (n,) beam index of each point (-1: not a scan return, never linked).
        points: (n, 3) the points (odom, m).
        origins: (n, 3) the scanner's origin for each (odom, m).
        angle_increment: angle between beams (rad).
        beam_count: beams in the scan (the last and the first are neighbours on a full turn).
        incidence: smallest angle (rad) between a beam and a surface it is still joined on.

    """
    b = np.asarray(beams, dtype=np.int64)
    scan = np.flatnonzero(b >= 0)
    step = abs(float(angle_increment))
    if scan.size < 2 or step <= 0.0 or incidence <= step:
        return np.zeros((0, 2), dtype=np.int64)
    order = scan[np.argsort(b[scan], kind="stable")]
    first, second = order[:-1], order[1:]
    if beam_count * step >= 2.0 * np.pi - 1e-9 and b[order[0]] == 0:
        first, second = np.append(first, order[-1]), np.append(second, order[0])
    gap = (b[second] - b[first]) % max(int(beam_count), 1)
    r = np.minimum(
        np.hypot(*(points[first, :2] - origins[first, :2]).T),
        np.hypot(*(points[second, :2] - origins[second, :2]).T),
    )
    reach = r * np.sin(step) / np.sin(incidence - step)
    close = np.linalg.norm(points[first] - points[second], axis=1) <= reach
    keep = (gap == 1) & close
    return np.column_stack([first[keep], second[keep]])


def cluster_labels(
    points: np.ndarray,
    voxel_size: float,
    tolerance: float,
    min_points: int,
    planar: bool = False,
    links: np.ndarray | None = None,
) -> np.ndarray:
    """(n,) cluster of each point (0, 1, ...), -1 for clusters of fewer than ``min_points``.

    ``planar``: distances on x-y only (vertical obstacles). ``links``: (m, 2) pairs of point
    indices joined whatever their distance. Clusters are numbered by decreasing size (ties
    by first point), so labels do not depend on the voxel numbering.
    """
    centroids, voxel = voxel_centroids(points, voxel_size)
    if centroids.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    voxel_links = None if links is None else voxel[np.asarray(links, dtype=np.int64)]
    coords = centroids[:, :2] if planar else centroids
    labels = connected_labels(coords, tolerance, voxel_links)[voxel]
    counts = np.bincount(labels)
    first = np.full(counts.size, labels.size)
    np.minimum.at(first, labels, np.arange(labels.size))
    order = np.lexsort((first, -counts))  # biggest first
    kept = order[counts[order] >= min_points]
    new = np.full(counts.size, -1, dtype=np.int64)
    new[kept] = np.arange(kept.size)
    return new[labels]
