"""Bounded work on floods: keep the nearest items of an over-long list.

A detector that reports 10,000 obstacles, or a message padded to megabytes, must not cost
the receiver unbounded time per cycle. The receiver keeps at most ``limit`` items, nearest
to the robot first (the ones a safety filter must see), and counts the rest as rejected.
"""

from __future__ import annotations

import numpy as np


def cap_nearest(centers: np.ndarray, reference: np.ndarray | None, limit: int) -> np.ndarray:
    """Indices (sorted ascending) of at most ``limit`` rows of ``centers`` nearest ``reference``.

    Args:
        centers: ``(n, k)`` positions (m), any frame shared with ``reference``; rows with
            NaN/Inf count as farthest (the receiver's validation rejects them later).
        reference: ``(k,)`` or ``(2,)`` robot position in the same frame (the first ``k``
            axes are used); None keeps the first ``limit`` rows.
        limit: how many to keep (>= 0).

    """
    n = len(centers)
    if n <= limit:
        return np.arange(n)
    if reference is None:
        return np.arange(limit)
    ref = np.asarray(reference, dtype=float).reshape(-1)
    k = min(ref.size, centers.shape[1])
    d = np.sum((centers[:, :k] - ref[:k]) ** 2, axis=1)
    d[~np.isfinite(d)] = np.inf
    keep = np.argpartition(d, limit - 1)[:limit] if limit > 0 else np.zeros(0, dtype=int)
    return np.sort(keep)
