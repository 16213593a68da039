"""Obstacle data types and the lifecycle of a single track.

Data types (what the ROS node converts messages to and from):

* :class:`ObstaclePlane` -- plane in which an obstacle's ellipse lies.
* :class:`Detection` -- one measured obstacle ellipse (odom frame).
* :class:`TrackedObstacle` -- an immutable snapshot of a track predicted to a given time.

Filter (:class:`Track`): a constant-velocity Kalman filter with a low process noise, so that
static and steadily moving obstacles get steady velocities, and a manoeuvre detector
(:mod:`safe_legged_c3bf.perception.maneuver`) that corrects it within a few detections when
the obstacle starts, stops or turns.

Lifecycle (:class:`Track`): a track is born *tentative* from an unassociated detection,
becomes *confirmed* once it has been hit in at least ``confirm_hits`` of the last
``confirm_window`` tracker cycles, *coasts* (is predicted with growing covariance) through
missed cycles, and is *deleted* when it has not been updated for longer than
``max_coast_time`` (confirmed) or ``tentative_max_coast_time`` (tentative).  Staleness is
measured in time, not in cycles, so it does not depend on the detector rate.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum

import numpy as np

from safe_legged_c3bf.interfaces.typed_params import (
    FLAG,
    NON_NEGATIVE,
    POSITIVE,
    TypedParams,
    at_least,
    interval,
    param,
)
from safe_legged_c3bf.perception.kalman import ConstantVelocityKalmanFilter, floored_covariance
from safe_legged_c3bf.perception.maneuver import ManeuverDetector

__all__ = [
    "Detection",
    "ObstaclePlane",
    "Track",
    "TrackConfig",
    "TrackStatus",
    "TrackedObstacle",
    "plane_axes",
]


class ObstaclePlane(IntEnum):
    """Plane of an obstacle ellipse.

    ``VERTICAL``: the ellipse lies in the x-y plane (an upright obstacle seen from above,
    e.g. a pillar or a person).  ``HORIZONTAL``: the ellipse lies in the x-z plane (a bar
    across the path that the robot must duck under or step over).
    """

    VERTICAL = 0
    HORIZONTAL = 1


class TrackStatus(StrEnum):
    """Lifecycle state of a track."""

    TENTATIVE = "tentative"
    CONFIRMED = "confirmed"
    DELETED = "deleted"


@dataclass(frozen=True, eq=False)
class Detection:
    """One measured obstacle.

    Attributes
    ----------
    center:
        Ellipse centre ``(x, y, z)`` in the odom frame (m).
    semi_axes:
        Semi-axes ``(a, b)`` of the ellipse in its plane (m); must be positive.
    orientation:
        Rotation of the ``a`` axis in the ellipse plane (rad): about +z for ``VERTICAL``
        (from +x towards +y), about +y for ``HORIZONTAL`` (from +x towards +z).
    plane:
        :class:`ObstaclePlane` of the ellipse.
    id:
        Identity reported by the detector; empty string when unknown.
    frame_id:
        Frame of ``center``; the tracker rejects detections not in its frame (``"odom"``).
    extent:
        Length along the extrusion axis (m): z for ``VERTICAL``, odom y for ``HORIZONTAL``
        (``Obstacle.msg`` field of the same name).  Must be > 0; ``inf`` (the default) means
        unbounded, the conservative choice.
    position_covariance:
        ``(3, 3)`` covariance of ``center`` (m^2, odom) as the detector reports it, or
        ``None`` (unknown: ``TrackConfig.measurement_std`` is used).  A detector knows which
        directions it measures poorly (the unseen far side of a cluster, the open end of a
        wall piece); with ``TrackConfig.use_detection_covariance`` the track's filter
        weighs the detection by it.

    """

    center: tuple[float, float, float] | np.ndarray
    semi_axes: tuple[float, float] | np.ndarray
    orientation: float = 0.0
    plane: ObstaclePlane = ObstaclePlane.VERTICAL
    id: str = ""
    frame_id: str = "odom"
    extent: float = math.inf
    position_covariance: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class TrackedObstacle:
    """Snapshot of a track predicted to time :attr:`stamp`.

    Attributes
    ----------
    track_id:
        Unique integer of the track inside its tracker (never reused).
    id:
        Detector identity if known, otherwise ``"track_<track_id>"``.
    plane:
        :class:`ObstaclePlane` of the most recent detection.
    stamp:
        Time the state was predicted to (s).
    center, velocity:
        Position (m) and velocity (m/s) in the odom frame, shape ``(3,)``.
    semi_axes, orientation, extent:
        Ellipse and extrusion length of the most recent detection (m, rad, m).
    position_covariance, velocity_covariance:
        3x3 covariance blocks (m^2, m^2/s^2) at :attr:`stamp`.
    velocity_estimated:
        True once the velocity is observable with the configured accuracy (enough hits and
        velocity standard deviation below the threshold).  Consumers should treat the
        velocity of tracks without this flag as unknown.
    status:
        :class:`TrackStatus` of the track.
    age:
        Time from the first detection to :attr:`stamp` (s).
    hits:
        Number of detections used by the track.
    consecutive_misses:
        Number of tracker cycles since the last detection (0 if updated in the last one).
    time_since_update:
        :attr:`stamp` minus the time of the last detection (s).

    """

    track_id: int
    id: str
    plane: ObstaclePlane
    stamp: float
    center: np.ndarray
    velocity: np.ndarray
    semi_axes: tuple[float, float]
    orientation: float
    extent: float
    position_covariance: np.ndarray
    velocity_covariance: np.ndarray
    velocity_estimated: bool
    status: TrackStatus
    age: float
    hits: int
    consecutive_misses: int
    time_since_update: float

    @property
    def coasting(self) -> bool:
        """True if the track missed at least its most recent cycle."""
        return self.consecutive_misses > 0

    @property
    def speed(self) -> float:
        """Norm of :attr:`velocity` (m/s)."""
        return float(np.linalg.norm(self.velocity))


@dataclass(frozen=True)
class TrackConfig(TypedParams):
    """Parameters of a track's filter and lifecycle (validated at construction).

    A track is confirmed after ``confirm_hits`` hits in the last ``confirm_window`` tracker
    cycles (N-of-M rule). Each field carries its unit and description.
    """

    accel_psd: float = param(
        0.0001, "m^2/s^3", "Kalman process noise, white acceleration spectral density. Low, so "
        "that a static obstacle's speed stays about 0.01 m/s RMS (0.025 m/s at most) with 2 cm "
        "measurement noise at 10 Hz; starts, stops and turns are followed by the manoeuvre "
        "detector (maneuver_*), without it only after 1.5-2 s", NON_NEGATIVE,
    )
    measurement_std: float = param(0.02, "m", "position measurement noise per axis", POSITIVE)
    use_detection_covariance: bool = param(
        False, "-", "weigh each detection by its own position covariance (Obstacle.msg "
        "position_covariance), floored at measurement_std^2 along every principal axis; "
        "false: measurement_std for every detection. Off by default: with the obstacle "
        "detector's covariances it measured no gain (config/obstacle_tracker.yaml) (flag)",
        FLAG,
    )
    initial_velocity_std: float = param(
        1.5, "m/s", "prior velocity standard deviation of a new track; covers walking speeds",
        POSITIVE,
    )
    confirm_hits: int = param(
        3, "-", "hits (a count) in the last confirm_window cycles that confirm a track",
        at_least(1),
    )
    confirm_window: int = param(
        5, "-", "tracker cycles (a count) of the N-of-M confirmation rule; >= confirm_hits",
        at_least(1),
    )
    max_coast_time: float = param(
        1.0, "s", "a confirmed track is deleted when not updated for longer than this",
        POSITIVE,
    )
    tentative_max_coast_time: float = param(
        0.2, "s", "a tentative track is deleted when not updated for longer than this",
        POSITIVE,
    )
    velocity_min_hits: int = param(
        5, "-", "least number of hits (a count) before velocity_estimated can be true",
        at_least(1),
    )
    velocity_std_threshold: float = param(
        0.2, "m/s", "largest velocity standard deviation (square root of the largest "
        "eigenvalue of the velocity covariance) for velocity_estimated to be true. A track "
        "whose velocity was estimated keeps the flag through a manoeuvre correction until its "
        "velocity is this accurate again", POSITIVE,
    )
    maneuver_detection: bool = param(
        True, "-", "detect starts, stops and turns in the recent innovations and correct the "
        "velocity at once (flag; perception/maneuver.py)", FLAG,
    )
    maneuver_false_alarm: float = param(
        1e-6, "-", "probability (unitless) that the chi-square test (2 dof, in the obstacle's "
        "plane) of one velocity-change onset passes while the velocity is constant; 1e-6 is a "
        "threshold of 27.6 on the drop of the NIS sum", interval(0.0, 1.0),
    )
    maneuver_window: int = param(
        5, "-", "updates (a count) kept for the manoeuvre test: the onsets searched; "
        ">= maneuver_min_updates", at_least(1),
    )
    maneuver_min_updates: int = param(
        3, "-", "least number of updates (a count) after an onset for a manoeuvre to be "
        "declared; with 3 a single outlying detection cannot cause one", at_least(1),
    )
    maneuver_velocity_std: float = param(
        1.0, "m/s", "standard deviation, per in-plane axis, of the velocity change allowed at "
        "an onset (the velocity variance added when the updates are processed again)",
        POSITIVE,
    )
    maneuver_fit_probability: float = param(
        0.01, "-", "chi-square tail probability (unitless) every innovation after the first "
        "of a manoeuvre hypothesis must pass (NIS below 9.2 for 0.01): outliers do not fit a "
        "change of velocity", interval(0.0, 1.0),
    )
    maneuver_noise_window: int = param(
        60, "-", "updates (a count) whose median NIS, relative to the chi-square median, "
        "scales the manoeuvre thresholds when above one (detections noisier than "
        "measurement_std); 0 disables the scaling", at_least(0),
    )
    maneuver_noise_scale_min: float = param(
        1.0, "-", "least factor (unitless) on the manoeuvre thresholds from the noise level: "
        "below 1, a track whose detections are steadier than measurement_std (median NIS "
        "under the chi-square median) is tested with thresholds lowered by that ratio down to "
        "this floor, so a start is found in fewer updates; 1: never below the configured ones",
        interval(0.0, 1.0, closed_high=True),
    )

    def __post_init__(self) -> None:
        """Validate the parameters (raises ``ValueError`` naming the bad one)."""
        self.validate()

    def check_together(self) -> None:
        """confirm_hits <= confirm_window; maneuver_min_updates <= maneuver_window."""
        if self.confirm_hits > self.confirm_window:
            raise ValueError(
                f"confirm_hits/confirm_window: need confirm_hits <= confirm_window, got "
                f"{self.confirm_hits!r}, {self.confirm_window!r}"
            )
        if self.maneuver_min_updates > self.maneuver_window:
            raise ValueError(
                f"maneuver_min_updates/maneuver_window: need maneuver_min_updates <= "
                f"maneuver_window, got {self.maneuver_min_updates!r}, {self.maneuver_window!r}"
            )

    def maneuver_detector(self) -> ManeuverDetector | None:
        """A new manoeuvre detector with these parameters, None if maneuver_detection is off."""
        if not self.maneuver_detection:
            return None
        return ManeuverDetector(
            false_alarm=self.maneuver_false_alarm,
            window=self.maneuver_window,
            min_updates=self.maneuver_min_updates,
            velocity_std=self.maneuver_velocity_std,
            fit_probability=self.maneuver_fit_probability,
            noise_window=self.maneuver_noise_window,
            noise_scale_min=self.maneuver_noise_scale_min,
        )


@dataclass
class _Appearance:
    semi_axes: tuple[float, float]
    orientation: float
    plane: ObstaclePlane
    extent: float
    source_id: str = field(default="")


def plane_axes(plane: ObstaclePlane) -> tuple[int, int]:
    """The two odom coordinates of an obstacle's plane: x-y (vertical) or x-z (horizontal)."""
    return (0, 2) if plane == ObstaclePlane.HORIZONTAL else (0, 1)


class Track:
    """One obstacle track: a constant-velocity Kalman filter plus its lifecycle.

    The tracker drives it once per cycle with either :meth:`update` (hit) or
    :meth:`mark_missed` (miss), and deletes it when :meth:`is_stale` becomes true.
    """

    def __init__(self, track_id: int, detection: Detection, t: float, config: TrackConfig) -> None:
        self.track_id = int(track_id)
        self.config = config
        center = np.asarray(detection.center, dtype=float).reshape(3)
        self.kf = ConstantVelocityKalmanFilter(
            center,
            t,
            accel_psd=config.accel_psd,
            measurement_std=config.measurement_std,
            initial_velocity_std=config.initial_velocity_std,
        )
        self._appearance = _Appearance(
            semi_axes=(float(detection.semi_axes[0]), float(detection.semi_axes[1])),
            orientation=float(detection.orientation),
            plane=ObstaclePlane(detection.plane),
            extent=float(detection.extent),
            source_id=str(detection.id),
        )
        self.created_at = float(t)
        self.last_update_time = float(t)
        self.growth_from = float(t)  # s: a coasting track's growth counts from here
        self.hits = 1
        self.consecutive_misses = 0
        self._history: deque[bool] = deque([True], maxlen=config.confirm_window)
        self._status = TrackStatus.TENTATIVE
        self._maneuver = config.maneuver_detector()
        self._held_estimated = False  # velocity_estimated kept through a manoeuvre correction
        self._check_confirmation()

    # ------------------------------------------------------------------ properties
    @property
    def status(self) -> TrackStatus:
        """Current :class:`TrackStatus`."""
        return self._status

    @property
    def confirmed(self) -> bool:
        """True for confirmed (possibly coasting) tracks."""
        return self._status is TrackStatus.CONFIRMED

    @property
    def source_id(self) -> str:
        """Detector identity of the track (empty if never reported)."""
        return self._appearance.source_id

    @property
    def id(self) -> str:
        """Public identity: the detector id, or ``track_<track_id>`` if unknown."""
        return self.source_id or f"track_{self.track_id}"

    @property
    def plane(self) -> ObstaclePlane:
        """Plane of the most recent detection."""
        return self._appearance.plane

    @property
    def maneuvers(self) -> int:
        """Manoeuvres (starts, stops, turns) detected and corrected so far."""
        return self._maneuver.count if self._maneuver is not None else 0

    # ------------------------------------------------------------------ lifecycle
    def _check_confirmation(self) -> None:
        if self._status is TrackStatus.TENTATIVE and sum(self._history) >= self.config.confirm_hits:
            self._status = TrackStatus.CONFIRMED

    def predicted_measurement(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Return predicted position and innovation covariance at ``t`` (no side effect)."""
        x, P = self.kf.state_at(t)
        S = P[:3, :3] + (self.config.measurement_std**2) * np.eye(3)
        return x[:3], S

    def update(self, detection: Detection, t: float) -> float:
        """Correct the track with an associated detection at time ``t``; return its NIS.

        The NIS is the plain Kalman update's; a manoeuvre detected afterwards corrects the
        estimate further (:mod:`safe_legged_c3bf.perception.maneuver`).
        """
        z = np.asarray(detection.center, dtype=float).reshape(3)
        R = self._measurement_noise(detection)
        if self._maneuver is None:
            self.kf.predict_to(max(float(t), self.kf.time))
            nis = self.kf.update(z, measurement_cov=R)
        else:
            nis = self._watched_update(self._maneuver, z, R, t, ObstaclePlane(detection.plane))
        source_id = str(detection.id) or self._appearance.source_id
        self._appearance = _Appearance(
            semi_axes=(float(detection.semi_axes[0]), float(detection.semi_axes[1])),
            orientation=float(detection.orientation),
            plane=ObstaclePlane(detection.plane),
            extent=float(detection.extent),
            source_id=source_id,
        )
        self.last_update_time = max(self.last_update_time, float(t))
        self.growth_from = max(self.growth_from, self.last_update_time)
        self.hits += 1
        self.consecutive_misses = 0
        self._history.append(True)
        self._check_confirmation()
        return nis

    def mark_missed(self) -> None:
        """Record a tracker cycle without an associated detection (coasting)."""
        self.consecutive_misses += 1
        self._history.append(False)

    def hold_growth(self, t: float) -> None:
        """Restart the coasting growth's clock at ``t`` (s): its place is seen occupied."""
        self.growth_from = max(self.growth_from, float(t))

    def is_stale(self, t: float) -> bool:
        """True if the track has not been updated for too long at time ``t``."""
        limit = (
            self.config.max_coast_time if self.confirmed else self.config.tentative_max_coast_time
        )
        return float(t) - self.last_update_time > limit

    def delete(self) -> None:
        """Mark the track deleted."""
        self._status = TrackStatus.DELETED

    def _measurement_noise(self, detection: Detection) -> np.ndarray | None:
        """The detection's covariance floored at measurement_std^2 (m^2), or None (module doc)."""
        cov = detection.position_covariance
        if cov is None or not self.config.use_detection_covariance:
            return None
        return floored_covariance(cov, self.config.measurement_std)

    def _watched_update(
        self, maneuver: ManeuverDetector, z: np.ndarray, R: np.ndarray | None, t: float,
        plane: ObstaclePlane,
    ) -> float:
        """The Kalman update, then the manoeuvre test on it; return the update's NIS."""
        prior = self.kf.snapshot()
        self.kf.predict_to(max(float(t), self.kf.time))
        estimated = self.velocity_estimated()
        innovation, covariance = self.kf.innovation(z, measurement_cov=R)
        nis = self.kf.update(z, measurement_cov=R)
        if maneuver.observe(self.kf, prior, z, innovation, covariance, plane_axes(plane),
                            test=estimated, measurement_cov=R):
            self._held_estimated = estimated
        elif self._held_estimated and self._velocity_accurate(self.kf.velocity_covariance):
            self._held_estimated = False
        return nis

    # ------------------------------------------------------------------ output
    def velocity_estimated(self, velocity_covariance: np.ndarray | None = None) -> bool:
        """True when the velocity estimate is trustworthy (see :class:`TrackConfig`).

        A track whose velocity was estimated when a manoeuvre was corrected stays estimated
        until its velocity is accurate again: its corrected velocity, though less certain (the
        covariance says how much), is better than none.
        """
        if self.hits < self.config.velocity_min_hits:
            return False
        if self._held_estimated:
            return True
        cov = self.kf.velocity_covariance if velocity_covariance is None else velocity_covariance
        return self._velocity_accurate(cov)

    def _velocity_accurate(self, velocity_covariance: np.ndarray) -> bool:
        largest = float(np.linalg.eigvalsh(velocity_covariance)[-1])
        return largest <= self.config.velocity_std_threshold**2

    @property
    def semi_axes(self) -> tuple[float, float]:
        """Semi-axes of the most recent detection (m)."""
        return self._appearance.semi_axes

    def snapshot(self, t: float, growth: float = 0.0) -> TrackedObstacle:
        """Return the track predicted to time ``t`` as a :class:`TrackedObstacle`.

        ``growth`` (m, >= 0) is added to both semi-axes (a coasting track's uncertainty).
        """
        t = float(t)
        x, P = self.kf.state_at(t)
        center = x[:3].copy()
        velocity = x[3:].copy()
        pos_cov = P[:3, :3].copy()
        vel_cov = P[3:, 3:].copy()
        for arr in (center, velocity, pos_cov, vel_cov):
            arr.setflags(write=False)
        app = self._appearance
        return TrackedObstacle(
            track_id=self.track_id,
            id=self.id,
            plane=app.plane,
            stamp=t,
            center=center,
            velocity=velocity,
            semi_axes=(app.semi_axes[0] + growth, app.semi_axes[1] + growth),
            orientation=app.orientation,
            extent=app.extent,
            position_covariance=pos_cov,
            velocity_covariance=vel_cov,
            velocity_estimated=self.velocity_estimated(P[3:, 3:]),
            status=self._status,
            age=t - self.created_at,
            hits=self.hits,
            consecutive_misses=self.consecutive_misses,
            time_since_update=t - self.last_update_time,
        )
