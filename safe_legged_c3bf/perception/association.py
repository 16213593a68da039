"""Detection-to-track association.

Two stages:

1. **By identity.**  A detection whose ``id`` is not empty is matched to the live track
   carrying the same identity, if any.
2. **Gated global nearest neighbour.**  The remaining detections (anonymous ones, and
   identified ones for which no track carries the identity yet) are assigned to the
   remaining tracks by minimising the summed squared Mahalanobis distance
   (:func:`scipy.optimize.linear_sum_assignment`).  Pairs outside the chi-square gate, in
   different obstacle planes, or with conflicting identities (an identified detection may
   only adopt an anonymous track) are forbidden.

The functions work on plain arrays and strings so that they can be tested without tracks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

__all__ = [
    "AssociationResult",
    "associate",
    "gate_threshold",
    "gated_assignment",
    "mahalanobis_cost_matrix",
]

# Stand-in for forbidden pairs inside linear_sum_assignment (it rejects all-inf rows).
_FORBIDDEN = 1e12


@dataclass(frozen=True)
class AssociationResult:
    """Outcome of :func:`associate`.

    Attributes
    ----------
    matches:
        ``(track_index, detection_index)`` pairs, sorted by track index.
    unmatched_tracks:
        Indices of tracks without a detection (sorted).
    unmatched_detections:
        Indices of detections without a track (sorted); they start new tracks.
    by_id:
        Number of matches made by identity.

    """

    matches: list[tuple[int, int]]
    unmatched_tracks: list[int]
    unmatched_detections: list[int]
    by_id: int = 0


def gate_threshold(probability: float, dim: int = 3) -> float:
    """Squared Mahalanobis gate holding a true measurement with ``probability``."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"gate probability must be in (0, 1), got {probability!r}")
    return float(chi2.ppf(probability, dim))


def mahalanobis_cost_matrix(
    predicted: np.ndarray, covariances: np.ndarray, measured: np.ndarray
) -> np.ndarray:
    """Squared Mahalanobis distances between predictions and measurements.

    Parameters
    ----------
    predicted:
        ``(n, d)`` predicted measurement of each track.
    covariances:
        ``(n, d, d)`` gating (innovation) covariance of each track.
    measured:
        ``(m, d)`` measurements.

    Returns
    -------
    numpy.ndarray
        ``(n, m)`` matrix of ``(z_j - zhat_i)^T S_i^-1 (z_j - zhat_i)``.

    """
    predicted = np.asarray(predicted, dtype=float)
    measured = np.asarray(measured, dtype=float)
    n, m = predicted.shape[0], measured.shape[0]
    if n == 0 or m == 0:
        return np.zeros((n, m))
    inv = np.linalg.inv(np.asarray(covariances, dtype=float))  # (n, d, d)
    diff = measured[None, :, :] - predicted[:, None, :]  # (n, m, d)
    return np.einsum("nmi,nij,nmj->nm", diff, inv, diff)


def gated_assignment(cost: np.ndarray, gate: float) -> list[tuple[int, int]]:
    """Globally optimal assignment restricted to entries ``cost <= gate``.

    Entries above the gate, infinite or NaN are forbidden.  Returns ``(row, col)`` pairs.
    """
    cost = np.asarray(cost, dtype=float)
    if cost.size == 0:
        return []
    allowed = np.isfinite(cost) & (cost <= gate)
    if not allowed.any():
        return []
    work = np.where(allowed, cost, _FORBIDDEN)
    rows, cols = linear_sum_assignment(work)
    return [(int(r), int(c)) for r, c in zip(rows, cols, strict=True) if allowed[r, c]]


def associate(
    track_ids: Sequence[str],
    track_planes: Sequence[int],
    detection_ids: Sequence[str],
    detection_planes: Sequence[int],
    cost: np.ndarray,
    gate: float,
) -> AssociationResult:
    """Associate detections with tracks, by identity first, then by gated distance.

    Parameters
    ----------
    track_ids:
        Detector identity of each track (empty string for anonymous tracks).  Non-empty
        identities must be unique.
    track_planes:
        Obstacle plane of each track.
    detection_ids:
        Identity of each detection (empty string when unknown).  Non-empty identities
        must be unique (the tracker drops duplicates beforehand).
    detection_planes:
        Obstacle plane of each detection.
    cost:
        ``(n_tracks, n_detections)`` squared Mahalanobis distances.
    gate:
        Largest accepted squared distance for stage 2.

    """
    n, m = len(track_ids), len(detection_ids)
    cost = np.asarray(cost, dtype=float).reshape(n, m)
    matches: list[tuple[int, int]] = []
    track_by_id = {tid: i for i, tid in enumerate(track_ids) if tid}
    used_tracks: set[int] = set()
    used_dets: set[int] = set()

    # Stage 1: identities.
    for j, did in enumerate(detection_ids):
        if did and did in track_by_id:
            i = track_by_id[did]
            matches.append((i, j))
            used_tracks.add(i)
            used_dets.add(j)
    by_id = len(matches)

    # Stage 2: gated global nearest neighbour on what is left.
    rows = [i for i in range(n) if i not in used_tracks]
    cols = [j for j in range(m) if j not in used_dets]
    if rows and cols:
        sub = cost[np.ix_(rows, cols)].copy()
        for a, i in enumerate(rows):
            for b, j in enumerate(cols):
                if int(track_planes[i]) != int(detection_planes[j]):
                    sub[a, b] = np.inf
                elif detection_ids[j] and track_ids[i]:
                    sub[a, b] = np.inf  # identities conflict (equal ids matched above)
        for a, b in gated_assignment(sub, gate):
            matches.append((rows[a], cols[b]))
            used_tracks.add(rows[a])
            used_dets.add(cols[b])

    matches.sort()
    return AssociationResult(
        matches=matches,
        unmatched_tracks=[i for i in range(n) if i not in used_tracks],
        unmatched_detections=[j for j in range(m) if j not in used_dets],
        by_id=by_id,
    )
