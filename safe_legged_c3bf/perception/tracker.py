"""Multi-obstacle tracker: validation, association, track management and prediction.

Usage::

    tracker = MultiObstacleTracker(TrackerConfig())
    tracker.update(detections, t)            # once per detector message
    obstacles = tracker.tracks_at(t_now)     # confirmed tracks predicted to t_now

All obstacles are tracked with a 3D (x, y, z) constant-velocity Kalman filter in the odom
frame, whatever their plane, and a manoeuvre detector that corrects the filter when an
obstacle starts, stops or turns (:mod:`safe_legged_c3bf.perception.maneuver`).  Bad
detections are dropped before association and counted by :class:`RejectionReason`.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from safe_legged_c3bf.interfaces.typed_params import (
    FLAG,
    NON_EMPTY,
    NON_NEGATIVE,
    POSITIVE,
    POSITIVE_OR_INF,
    TypedParams,
    at_least,
    group,
    interval,
    param,
)
from safe_legged_c3bf.perception.association import (
    associate,
    gate_threshold,
    mahalanobis_cost_matrix,
)
from safe_legged_c3bf.perception.hidden_tracks import inside_vertical_detections
from safe_legged_c3bf.perception.scan_clearing import ClearingConfig, SeenFree, seen_through
from safe_legged_c3bf.perception.track import (
    Detection,
    ObstaclePlane,
    Track,
    TrackConfig,
    TrackedObstacle,
)
from safe_legged_c3bf.safety import cap_nearest

__all__ = [
    "MultiObstacleTracker",
    "RejectionReason",
    "TrackerConfig",
    "UpdateReport",
    "validate_detection",
]


class RejectionReason(StrEnum):
    """Why a detection (or a whole batch) was dropped."""

    MALFORMED = "malformed"  # wrong shapes/types or unknown plane
    NON_FINITE = "non_finite"  # NaN/Inf in centre, semi-axes, orientation; NaN extent
    NON_POSITIVE_SIZE = "non_positive_size"  # a semi-axis or the extent <= 0
    TOO_LARGE = "too_large"  # a semi-axis above TrackerConfig.max_semi_axis
    WRONG_FRAME = "wrong_frame"  # frame_id differs from the tracker frame
    OUT_OF_RANGE = "out_of_range"  # farther than TrackerConfig.max_range
    DUPLICATE_ID = "duplicate_id"  # same non-empty id twice in one batch
    STALE_TIMESTAMP = "stale_timestamp"  # batch older than max_reorder before the newest one
    TOO_MANY = "too_many"  # beyond max_detections in one batch (the farthest are dropped)


@dataclass(frozen=True)
class TrackerConfig(TypedParams):
    """Tracker parameters (validated at construction); ``track``: per-track parameters.

    Each field carries its unit and description.
    """

    frame_id: str = param("odom", "-", "frame every detection must be expressed in (a name)",
                          NON_EMPTY)
    max_range: float = param(
        15.0, "m", "detections farther than this from the reference point (the robot "
        "position passed to MultiObstacleTracker.update, else the frame origin) are rejected",
        POSITIVE_OR_INF,
    )
    max_semi_axis: float = param(
        5.0, "m", "detections with a larger semi-axis are rejected as implausible",
        POSITIVE_OR_INF,
    )
    gate_probability: float = param(
        0.9999, "-", "probability (unitless) mass of the chi-square (3 dof) association gate",
        interval(0.0, 1.0),
    )
    gate_floor: float = param(
        0.1, "m", "standard deviation added isotropically to the innovation covariance for "
        "gating and assignment only. It absorbs unmodelled maneuvers: with the low default "
        "process noise the Kalman innovation covariance is a few centimetres wide, and a "
        "walking obstacle that turns sharply would otherwise fall out of its own gate",
        NON_NEGATIVE,
    )
    max_detections: int = param(
        64, "-", "detections (a count) kept from one batch, nearest to the robot first; the "
        "rest are rejected as too_many (bounded work on a flood)", at_least(1),
    )
    max_reorder: float = param(
        0.5, "s", "a batch may be up to this much older than the newest one processed and is "
        "still used: two detectors on one topic, or one delayed frame, are merged instead of "
        "rejected. Older batches are rejected as stale_timestamp", NON_NEGATIVE,
    )
    keep_near_distance: float = param(
        1.5, "m", "a confirmed track whose ellipse comes within this distance of the robot is "
        "kept past max_coast_time while the robot moves: an obstacle close by that stops being "
        "detected (drop-out, occlusion, a poisoned or lost frame) is not forgotten",
        NON_NEGATIVE,
    )
    keep_near_max_coast_time: float = param(
        5.0, "s", "longest a near track is kept without an update while the robot moves",
        NON_NEGATIVE,
    )
    robot_stopped_speed: float = param(
        0.05, "m/s", "the robot counts as stopped below this planar speed; near tracks are "
        "then deleted by the ordinary max_coast_time rule", NON_NEGATIVE,
    )
    coast_growth: float = param(
        0.3, "m/s", "growth of a coasting track's semi-axes per second without an update, "
        "after coast_growth_after: the published ellipse covers where the unseen obstacle may "
        "have gone", NON_NEGATIVE,
    )
    coast_growth_after: float = param(
        0.3, "s", "time without an update before the semi-axes start to grow: a few detection "
        "periods, so ordinary gaps between frames do not grow obstacles", NON_NEGATIVE,
    )
    hold_growth_inside: bool = param(
        True, "-", "a coasting vertical track whose predicted centre lies inside a vertical "
        "detection of the batch does not grow: what is detected there fills its place "
        "(perception/hidden_tracks.py) (flag)", FLAG,
    )
    scan_clearing: bool = param(
        False, "-", "delete a coasting track whose place the 2-D LiDAR's beams pass right "
        "through (perception/scan_clearing.py; the node subscribes to the scan) (flag)", FLAG,
    )
    clear_after: float = param(
        0.25, "s", "time without an update before the scan may clear a track", NON_NEGATIVE,
    )
    clear_scans: int = param(
        2, "-", "consecutive scans (a count) that must see through a track to clear it",
        at_least(1),
    )
    clear_min_beams: int = param(
        3, "-", "readable beams (a count) that must cross a track's core", at_least(1),
    )
    clear_margin: float = param(
        0.1, "m", "each of them must reach this far beyond the core's far side", NON_NEGATIVE,
    )
    clear_height_tolerance: float = param(
        0.05, "m", "a track whose top is lower than the scan plane by more than this is never "
        "cleared (the LiDAR passes over it)", POSITIVE,
    )
    track: TrackConfig = group(TrackConfig)

    def clearing(self) -> ClearingConfig:
        """The ``clear_*`` parameters as the clearing module takes them."""
        return ClearingConfig(
            self.clear_after, self.clear_scans, self.clear_min_beams, self.clear_margin,
            self.clear_height_tolerance,
        )

    def __post_init__(self) -> None:
        """Validate the parameters (raises ``ValueError`` naming the bad one)."""
        self.validate()


@dataclass(frozen=True)
class UpdateReport:
    """What one :meth:`MultiObstacleTracker.update` call did.

    Attributes
    ----------
    accepted:
        Number of detections that passed validation.
    rejected:
        ``(detection_index, reason)`` for each dropped detection.
    matched:
        Number of detections associated with existing tracks.
    created:
        ``track_id`` of tracks started in this call.
    deleted:
        ``track_id`` of tracks deleted in this call (stale).

    """

    accepted: int
    rejected: list[tuple[int, RejectionReason]]
    matched: int
    created: list[int]
    deleted: list[int]


def validate_detection(
    detection: Detection,
    *,
    frame_id: str = "odom",
    max_range: float = math.inf,
    max_semi_axis: float = math.inf,
    reference: Sequence[float] | np.ndarray | None = None,
) -> RejectionReason | None:
    """Return why ``detection`` is unusable, or ``None`` if it is fine."""
    try:
        center = np.asarray(detection.center, dtype=float)
        axes = np.asarray(detection.semi_axes, dtype=float)
        orientation = float(detection.orientation)
        extent = float(detection.extent)
        ObstaclePlane(detection.plane)
        cov = _covariance_of(detection)
        if not isinstance(detection.id, str) or not isinstance(detection.frame_id, str):
            return RejectionReason.MALFORMED
    except (TypeError, ValueError, AttributeError):
        return RejectionReason.MALFORMED
    if center.shape != (3,) or axes.shape != (2,) or (cov is not None and cov.shape != (3, 3)):
        return RejectionReason.MALFORMED
    if not (
        np.all(np.isfinite(center)) and np.all(np.isfinite(axes)) and math.isfinite(orientation)
    ) or math.isnan(extent) or (cov is not None and not np.all(np.isfinite(cov))):
        return RejectionReason.NON_FINITE
    if np.any(axes <= 0.0) or extent <= 0.0:
        return RejectionReason.NON_POSITIVE_SIZE
    if np.any(axes > max_semi_axis):
        return RejectionReason.TOO_LARGE
    if detection.frame_id != frame_id:
        return RejectionReason.WRONG_FRAME
    ref = _reference_point(reference)
    if float(np.linalg.norm(center - ref)) > max_range:
        return RejectionReason.OUT_OF_RANGE
    return None


def _covariance_of(detection: Detection) -> np.ndarray | None:
    """The detection's position covariance as an array (None when it reports none)."""
    cov = getattr(detection, "position_covariance", None)
    return None if cov is None else np.asarray(cov, dtype=float)


def _reference_point(reference: Sequence[float] | np.ndarray | None) -> np.ndarray:
    """Range reference as a 3-vector; the origin if missing or unusable."""
    if reference is None:
        return np.zeros(3)
    try:
        ref = np.asarray(reference, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        return np.zeros(3)
    if ref.size == 2:
        ref = np.append(ref, 0.0)
    if ref.shape != (3,) or not np.all(np.isfinite(ref)):
        return np.zeros(3)
    return ref


class MultiObstacleTracker:
    """Track several ellipse obstacles from (possibly anonymous) detections.

    Parameters
    ----------
    config:
        :class:`TrackerConfig`; defaults are used when omitted.

    """

    def __init__(self, config: TrackerConfig | None = None) -> None:
        self.config = config if config is not None else TrackerConfig()
        self._gate = gate_threshold(self.config.gate_probability, 3)
        self._tracks: list[Track] = []
        self._next_track_id = 1
        self._last_time: float | None = None
        self._rejections: Counter[str] = Counter()
        self._robot_position: np.ndarray | None = None  # odom (m)
        self._robot_moving = False
        self._maneuvers = 0
        self._seen_through: dict[int, int] = {}  # track_id -> scans in a row that saw through

    # ------------------------------------------------------------------ state
    @property
    def rejection_counts(self) -> dict[str, int]:
        """Total number of rejected detections per :class:`RejectionReason` value."""
        return {reason.value: self._rejections[reason.value] for reason in RejectionReason}

    @property
    def maneuver_count(self) -> int:
        """Manoeuvres (starts, stops, turns of obstacles) detected since construction."""
        return self._maneuvers

    @property
    def tracks(self) -> list[Track]:
        """Live tracks (tentative and confirmed), oldest first."""
        return list(self._tracks)

    @property
    def last_update_time(self) -> float | None:
        """Time of the last processed batch, ``None`` before the first one."""
        return self._last_time

    def reset(self) -> None:
        """Drop all tracks and the time reference (rejection counters are kept)."""
        self._tracks.clear()
        self._last_time = None
        self._seen_through.clear()

    def observe_robot(self, position: Sequence[float], speed: float) -> None:
        """The robot's position (odom, m) and planar speed (m/s), for keeping near tracks."""
        pos = np.asarray(position, dtype=float).reshape(-1)[:3]
        if pos.size >= 2 and np.all(np.isfinite(pos)) and math.isfinite(speed):
            self._robot_position = pos
            self._robot_moving = speed > self.config.robot_stopped_speed

    def _kept_near(self, trk: Track, t: float) -> bool:
        """A confirmed track near the moving robot is kept past its coast time (see config)."""
        cfg = self.config
        if not (trk.confirmed and self._robot_moving and self._robot_position is not None):
            return False
        if t - trk.last_update_time > cfg.keep_near_max_coast_time:
            return False
        center = trk.kf.state_at(t)[0][:2]
        gap = float(np.linalg.norm(center - self._robot_position[:2])) - max(trk.semi_axes)
        return gap < cfg.keep_near_distance

    def clear_seen_through(self, seen: SeenFree) -> list[int]:
        """Delete the tracks a scan has seen through ``clear_scans`` times in a row.

        Only with ``scan_clearing``; returns the deleted ``track_id`` values
        (``perception/scan_clearing.py`` says which tracks a scan can clear).
        """
        if not self.config.scan_clearing or not math.isfinite(seen.stamp):
            return []
        clearing = self.config.clearing()
        counts: dict[int, int] = {}
        deleted: list[int] = []
        alive: list[Track] = []
        for trk in self._tracks:
            if trk.confirmed and trk.plane is ObstaclePlane.VERTICAL and (
                seen.stamp - trk.last_update_time >= clearing.after
            ) and self._seen_through_by(seen, trk, clearing):
                counts[trk.track_id] = self._seen_through.get(trk.track_id, 0) + 1
            if counts.get(trk.track_id, 0) >= clearing.scans:
                trk.delete()
                deleted.append(trk.track_id)
                del counts[trk.track_id]
            else:
                alive.append(trk)
        self._tracks = alive
        self._seen_through = counts
        return deleted

    @staticmethod
    def _seen_through_by(seen: SeenFree, trk: Track, clearing: ClearingConfig) -> bool:
        """Whether ``seen`` passes through ``trk``'s core, predicted to the scan's stamp."""
        last = trk.snapshot(trk.last_update_time)
        top = float(last.center[2]) + 0.5 * float(last.extent)
        now = trk.kf.state_at(seen.stamp)[0]
        return seen_through(seen, now[:2], min(last.semi_axes), top, clearing)

    def _is_stale(self, trk: Track, t: float) -> bool:
        return trk.is_stale(t) and not self._kept_near(trk, t)

    # ------------------------------------------------------------------ update
    def update(
        self,
        detections: Iterable[Detection],
        t: float,
        robot_position: Sequence[float] | np.ndarray | None = None,
    ) -> UpdateReport:
        """Process one batch of detections stamped ``t`` (s).

        Parameters
        ----------
        detections:
            Detections of one sensor message.  A tracked obstacle absent from the batch is
            counted as a miss for its track.
        t:
            Time stamp of the batch.  Batches more than ``max_reorder`` older than the newest
            one are rejected as a whole (each detection counted as ``stale_timestamp``).
        robot_position:
            Reference point ``(x, y[, z])`` for the range check (odom frame); the origin if
            omitted or not finite.

        """
        detections = list(detections)
        t = float(t)
        if not math.isfinite(t) or (
            self._last_time is not None and t < self._last_time - self.config.max_reorder
        ):
            rejected = [(k, RejectionReason.STALE_TIMESTAMP) for k in range(len(detections))]
            self._count(rejected)
            return UpdateReport(0, rejected, 0, [], [])
        valid, rejected = self._validated(detections, robot_position)
        result = self._associate(valid, t)
        tracks = self._tracks
        for i, j in result.matches:
            before = tracks[i].maneuvers
            tracks[i].update(valid[j], t)
            self._maneuvers += tracks[i].maneuvers - before
        for i in result.unmatched_tracks:
            tracks[i].mark_missed()
        if self.config.hold_growth_inside:
            self._hold_growth_inside([tracks[i] for i in result.unmatched_tracks], valid, t)
        created: list[int] = []
        for j in result.unmatched_detections:
            trk = Track(self._next_track_id, valid[j], t, self.config.track)
            self._next_track_id += 1
            self._tracks.append(trk)
            created.append(trk.track_id)
        deleted: list[int] = []
        alive: list[Track] = []
        for trk in self._tracks:
            if self._is_stale(trk, t):
                trk.delete()
                deleted.append(trk.track_id)
            else:
                alive.append(trk)
        self._tracks = alive
        self._last_time = t if self._last_time is None else max(self._last_time, t)
        return UpdateReport(len(valid), rejected, len(result.matches), created, deleted)

    @staticmethod
    def _hold_growth_inside(unseen: list[Track], valid: list[Detection], t: float) -> None:
        """Stop the growth of the unseen vertical tracks a detection covers (module doc)."""
        unseen = [trk for trk in unseen if trk.plane is ObstaclePlane.VERTICAL]
        if not unseen or not valid:
            return
        centers = np.array([trk.kf.state_at(t)[0][:2] for trk in unseen])
        for trk, covered in zip(unseen, inside_vertical_detections(centers, valid), strict=True):
            if covered:
                trk.hold_growth(t)

    def _validated(
        self, detections: list[Detection], robot_position: Sequence[float] | np.ndarray | None
    ) -> tuple[list[Detection], list[tuple[int, RejectionReason]]]:
        """The usable detections (capped nearest first) and the rejected ones, counted."""
        cfg = self.config
        index = list(range(len(detections)))  # original index of each detection kept
        rejected: list[tuple[int, RejectionReason]] = []
        if len(detections) > cfg.max_detections:
            index, rejected = self._cap(detections, robot_position)
        valid: list[Detection] = []
        seen_ids: set[str] = set()
        for k in index:
            det = detections[k]
            reason = validate_detection(
                det, frame_id=cfg.frame_id, max_range=cfg.max_range,
                max_semi_axis=cfg.max_semi_axis, reference=robot_position,
            )
            if reason is None and det.id:
                if det.id in seen_ids:
                    reason = RejectionReason.DUPLICATE_ID
                seen_ids.add(det.id)
            if reason is None:
                valid.append(det)
            else:
                rejected.append((k, reason))
        self._count(rejected)
        return valid, rejected

    def _associate(self, valid: list[Detection], t: float):  # noqa: ANN202 - association result
        """Optimal assignment of ``valid`` to the tracks predicted to ``t`` (gated)."""
        tracks = self._tracks
        if tracks and valid:
            predicted = np.empty((len(tracks), 3))
            covs = np.empty((len(tracks), 3, 3))
            floor = (self.config.gate_floor**2) * np.eye(3)
            for i, trk in enumerate(tracks):
                zhat, S = trk.predicted_measurement(t)
                predicted[i] = zhat
                covs[i] = S + floor
            measured = np.array([np.asarray(d.center, dtype=float) for d in valid])
            cost = mahalanobis_cost_matrix(predicted, covs, measured)
        else:
            cost = np.zeros((len(tracks), len(valid)))
        return associate(
            [trk.source_id for trk in tracks],
            [int(trk.plane) for trk in tracks],
            [d.id for d in valid],
            [int(d.plane) for d in valid],
            cost,
            self._gate,
        )

    def _cap(
        self, detections: list[Detection], robot_position: Sequence[float] | np.ndarray | None
    ) -> tuple[list[int], list[tuple[int, RejectionReason]]]:
        """Indices of the ``max_detections`` nearest the robot; the rest as ``too_many``."""
        centers = np.full((len(detections), 3), np.inf)
        for k, det in enumerate(detections):
            try:
                centers[k] = np.asarray(det.center, dtype=float).reshape(3)
            except (TypeError, ValueError):
                pass  # malformed: counted as farthest, rejected below if kept
        keep = cap_nearest(centers, _reference_point(robot_position), self.config.max_detections)
        kept = set(keep.tolist())
        dropped = [(k, RejectionReason.TOO_MANY) for k in range(len(detections)) if k not in kept]
        return sorted(kept), dropped

    def _count(self, rejected: list[tuple[int, RejectionReason]]) -> None:
        for _, reason in rejected:
            self._rejections[reason.value] += 1

    # ------------------------------------------------------------------ output
    def tracks_at(self, t: float, include_tentative: bool = False) -> list[TrackedObstacle]:
        """Return the tracks predicted to time ``t``, ordered by ``track_id``.

        Tracks that would be stale at ``t`` (not updated for longer than their coast time,
        e.g. because the detector stopped publishing) are left out.  Tentative tracks are
        only included on request.
        """
        t = float(t)
        if not math.isfinite(t):
            raise ValueError("t must be finite")
        out = []
        cfg = self.config
        for trk in self._tracks:
            if self._is_stale(trk, t) or (not include_tentative and not trk.confirmed):
                continue
            growing = t - trk.growth_from - cfg.coast_growth_after  # s the ellipse has grown
            out.append(trk.snapshot(t, cfg.coast_growth * max(growing, 0.0)))
        return out
