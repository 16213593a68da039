"""Manoeuvre detection for one track: a change of velocity found in its recent innovations.

A track's constant-velocity Kalman filter (:mod:`.kalman`) has a low process noise, so that
static and steadily moving obstacles get steady velocities. On its own such a filter follows
an obstacle that starts, stops or turns only after a second or so. :class:`ManeuverDetector`
tests after every update whether the last few innovations are better explained by a jump in
velocity, and if so corrects the filter at once.

**Test** (the generalised likelihood ratio of a jump, Willsky and Jones 1976, computed by
processing the updates again). The detector keeps the last ``window`` updates of the track:
the measured position, the filter's estimate before the update, and the normalised
innovation squared (NIS) and log-determinant of the innovation covariance, both in the
obstacle's plane (x-y for a vertical obstacle, x-z for a horizontal one; the centre along
the extrusion axis is poorly measured and is left out). For each onset ``j`` (the velocity
changed after the estimate that preceded update ``j``) it processes updates ``j..k`` again
from that estimate with the in-plane velocity variance increased by ``velocity_std**2``. The
drop of the NIS sum

    l_j = sum_{i >= j} NIS_i (as filtered) - sum_{i >= j} NIS_i (processed again)

is chi-square distributed with 2 degrees of freedom while the velocity does not change. A
manoeuvre is declared when for some onset backed by at least ``min_updates`` updates
``l_j > chi2.isf(false_alarm, 2)`` and every innovation of the processed-again updates after
the first passes ``chi2.isf(fit_probability, 2)``: a change of velocity explains all of them,
an outlier (one detection far off) does not, and with ``min_updates`` >= 3 a single outlier
never backs an onset alone.

**Outliers**: one detection far off pulls the filter's position, and the detections after it,
back where the obstacle is, then look like a motion. So the detector also tests the other
explanation of large innovations: update ``i`` (not the newest: a later one must contradict
it) was an outlier. The kept updates after it are processed again without it; its drop of the
NIS sum is compared with the best onset's. When the outlier explains more (and the updates
after it pass the fit test), the filter is set to the estimate without it and no manoeuvre is
declared.

**Correction**: the filter's estimate becomes the mixture of the processed-again estimates of
the onsets that pass the fit test and are backed by at least two updates (one update cannot
tell an onset from an outlier), weighted by their likelihood over the window (their NIS and
log-determinants) and moment-matched, so that an uncertain onset shows in the covariance. The
kept updates are then dropped: the next test starts from the corrected estimate.

**Noise level**: both thresholds are multiplied by the ratio of the median of the track's last
``noise_window`` in-plane NIS values to the chi-square median, clipped below at
``noise_scale_min`` (1 by default). A detection whose jitter exceeds the configured
measurement noise (far obstacles, clutter) then needs correspondingly more evidence. With
``noise_scale_min`` < 1 a detection steadier than the configured noise (a near obstacle in
full view of a LiDAR: millimetres, against the 2 cm configured for the worst case) needs
correspondingly less, down to that floor: the test keeps its false-alarm probability under
the noise measured instead of the noise configured, and a start shows in fewer updates.

**When**: the test runs once the track's velocity is estimated (the caller says so) and,
with the noise scaling on, the noise level has been measured on 10 updates: a new track's
filter is still converging and needs no correction.

**Cost**: processing again (``window`` onsets, at most ``window`` updates each) happens only
when the NIS sum of the kept updates exceeds the threshold, a bound for every ``l_j``: rarely
for a steady track.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from safe_legged_c3bf.perception.kalman import ConstantVelocityKalmanFilter, FilterState

__all__ = ["ManeuverDetector", "in_plane_terms"]

#: Degrees of freedom of the test: the two in-plane velocity components.
_DOF = 2
#: Least number of updates behind an onset used for the corrected estimate.
_ESTIMATE_MIN_UPDATES = 2
#: In-plane NIS values needed before the noise level is estimated.
_NOISE_MIN_SAMPLES = 10


def in_plane_terms(
    innovation: np.ndarray, covariance: np.ndarray, axes: Sequence[int]
) -> tuple[float, float]:
    """NIS and log-determinant of the innovation restricted to the coordinates ``axes``."""
    idx = list(axes)
    y = np.asarray(innovation, dtype=float)[idx]
    S = np.asarray(covariance, dtype=float)[np.ix_(idx, idx)]
    sign, logdet = np.linalg.slogdet(S)
    if sign <= 0.0:
        raise ValueError("innovation covariance must be positive definite")
    return float(y @ np.linalg.solve(S, y)), float(logdet)


@dataclass(frozen=True, eq=False)
class _Update:
    """One kept update: when, what was measured, the estimate before it, its in-plane terms."""

    time: float
    z: np.ndarray
    prior: FilterState
    nis: float
    logdet: float
    R: np.ndarray | None  # the measurement's own covariance (m^2), None: the filter's


@dataclass(frozen=True, eq=False)
class _Onset:
    """One onset hypothesis processed again."""

    updates: int  # updates behind the onset
    drop: float  # l_j, the drop of the NIS sum
    cost: float  # -2 log-likelihood of the whole window (up to a constant)
    fits: bool  # every innovation after the first passed the fit test
    estimate: FilterState


class ManeuverDetector:
    """Detects a change of velocity in a track's updates and corrects its filter.

    Parameters (see :class:`~safe_legged_c3bf.perception.TrackConfig`, ``maneuver_*``):
    ``false_alarm`` and ``fit_probability`` are chi-square tail probabilities in (0, 1);
    ``window`` >= ``min_updates`` >= 1 are counts of updates; ``velocity_std`` (m/s) > 0;
    ``noise_window`` >= 0 updates (0: the thresholds are not scaled); ``noise_scale_min``
    in (0, 1], the least factor on the thresholds.
    """

    def __init__(
        self,
        *,
        false_alarm: float = 1e-6,
        window: int = 5,
        min_updates: int = 3,
        velocity_std: float = 1.0,
        fit_probability: float = 0.01,
        noise_window: int = 60,
        noise_scale_min: float = 1.0,
    ) -> None:
        for name, p in (("false_alarm", false_alarm), ("fit_probability", fit_probability)):
            if not (math.isfinite(p) and 0.0 < p < 1.0):
                raise ValueError(f"{name} must be in (0, 1), got {p!r}")
        if not 1 <= int(min_updates) <= int(window):
            raise ValueError(f"need 1 <= min_updates <= window, got {min_updates!r}, {window!r}")
        if not (math.isfinite(velocity_std) and velocity_std > 0.0):
            raise ValueError(f"velocity_std must be finite and > 0, got {velocity_std!r}")
        if int(noise_window) < 0:
            raise ValueError(f"noise_window must be >= 0, got {noise_window!r}")
        if not (math.isfinite(noise_scale_min) and 0.0 < noise_scale_min <= 1.0):
            raise ValueError(f"noise_scale_min must be in (0, 1], got {noise_scale_min!r}")
        self.noise_scale_min = float(noise_scale_min)
        self.threshold = float(chi2.isf(false_alarm, _DOF))
        self.fit_threshold = float(chi2.isf(fit_probability, _DOF))
        self.min_updates = int(min_updates)
        self.velocity_variance = float(velocity_std) ** 2
        self._updates: deque[_Update] = deque(maxlen=int(window))
        self._noise: deque[float] | None = (
            deque(maxlen=int(noise_window)) if int(noise_window) > 0 else None
        )
        self._axes: tuple[int, ...] | None = None
        self.count = 0  # manoeuvres detected (corrections made)

    @property
    def noise_scale(self) -> float:
        """Factor on both thresholds: the median NIS over the chi-square one, >= noise_scale_min.

        1 until the noise is measured.
        """
        if not self._noise_measured:
            return 1.0
        ratio = float(np.median(self._noise)) / float(chi2.median(_DOF))
        return max(self.noise_scale_min, ratio)

    @property
    def _noise_measured(self) -> bool:
        noise = self._noise
        return noise is not None and len(noise) >= min(_NOISE_MIN_SAMPLES, noise.maxlen or 1)

    def reset(self) -> None:
        """Forget the kept updates (the noise level is kept)."""
        self._updates.clear()

    def observe(
        self,
        kf: ConstantVelocityKalmanFilter,
        prior: FilterState,
        z: np.ndarray,
        innovation: np.ndarray,
        covariance: np.ndarray,
        axes: Sequence[int],
        test: bool = True,
        measurement_cov: np.ndarray | None = None,
    ) -> bool:
        """Take the update ``kf`` just made; correct ``kf`` and return True on a manoeuvre.

        ``prior`` is the estimate before the update (before its prediction), ``z`` the measured
        position, ``innovation`` and ``covariance`` the update's innovation and its covariance,
        ``axes`` the coordinates of the obstacle's plane (two of 0, 1, 2). With ``test`` False
        (a velocity not yet estimated) the update is only kept. ``measurement_cov`` (m^2): the
        update's measurement covariance when it had its own; used again when processing again.
        """
        axes = tuple(int(a) for a in axes)
        if axes != self._axes:  # a new plane: the kept updates measured other coordinates
            self._updates.clear()
            self._axes = axes
        nis, logdet = in_plane_terms(innovation, covariance, axes)
        scale = self.noise_scale
        if self._noise is not None:
            self._noise.append(nis)
        self._updates.append(
            _Update(kf.time, np.array(z, dtype=float), prior, nis, logdet, measurement_cov))
        if not test or (self._noise is not None and not self._noise_measured):
            return False
        updates = list(self._updates)
        limit = self.threshold * scale
        if len(updates) < self.min_updates or sum(u.nis for u in updates) <= limit:
            return False  # no onset can pass: each l_j is at most this sum
        onsets = [self._onset(kf, updates, j, scale) for j in range(len(updates))]
        drop = max(
            (o.drop for o in onsets if o.fits and o.updates >= self.min_updates), default=-1.0
        )
        outlier = max(
            (self._without(kf, updates, i, scale) for i in range(len(updates) - 1)),
            key=lambda o: o.drop if o.fits else -math.inf, default=None,
        )
        if outlier is not None and outlier.fits and outlier.drop > limit and outlier.drop >= drop:
            kf.restore(outlier.estimate)
            self._updates.clear()
            return False
        if drop <= limit:
            return False
        least = min(_ESTIMATE_MIN_UPDATES, self.min_updates)
        kf.restore(_mixture([o for o in onsets if o.fits and o.updates >= least]))
        self._updates.clear()
        self.count += 1
        return True

    def _onset(
        self, kf: ConstantVelocityKalmanFilter, updates: list[_Update], j: int, scale: float
    ) -> _Onset:
        """Updates ``j..`` processed again after a velocity change before update ``j``."""
        f = kf.copy()
        f.restore(updates[j].prior)
        f.add_velocity_variance(self.velocity_variance, self._axes or ())
        pre = sum(u.nis + u.logdet for u in updates[:j])
        drop, cost, fits = self._replay(f, updates[j:], scale, 1, 0.0, pre)
        return _Onset(len(updates) - j, drop, cost, fits, f.snapshot())

    def _without(
        self, kf: ConstantVelocityKalmanFilter, updates: list[_Update], i: int, scale: float
    ) -> _Onset:
        """Updates ``i+1..`` processed again without update ``i`` (an outlier)."""
        f = kf.copy()
        f.restore(updates[i].prior)
        drop, _, fits = self._replay(f, updates[i + 1:], scale, 0, updates[i].nis, 0.0)
        return _Onset(len(updates) - i - 1, drop, 0.0, fits, f.snapshot())

    def _replay(
        self, f: ConstantVelocityKalmanFilter, later: list[_Update], scale: float,
        fit_from: int, drop: float, cost: float,
    ) -> tuple[float, float, bool]:
        """Process ``later`` again with ``f``; ``(drop, cost, fits)`` added to ``drop``/``cost``.

        ``fits``: every innovation from the ``fit_from``-th on passes the fit test.
        """
        axes = self._axes or ()
        fits = True
        for k, u in enumerate(later):
            f.predict_to(u.time)
            y, S = f.innovation(u.z, measurement_cov=u.R)
            nis, logdet = in_plane_terms(y, S, axes)
            f.update(u.z, measurement_cov=u.R)
            drop += u.nis - nis
            cost += nis + logdet
            if k >= fit_from and nis > self.fit_threshold * scale:
                fits = False
        return drop, cost, fits


def _mixture(onsets: list[_Onset]) -> FilterState:
    """Moment-matched mixture of the onsets' estimates, weighted by their likelihood."""
    cost = np.array([o.cost for o in onsets])
    w = np.exp(-0.5 * (cost - cost.min()))
    w /= w.sum()
    x = sum(wi * o.estimate.x for wi, o in zip(w, onsets, strict=True))
    P = sum(
        wi * (o.estimate.P + np.outer(o.estimate.x - x, o.estimate.x - x))
        for wi, o in zip(w, onsets, strict=True)
    )
    return FilterState(np.asarray(x), np.asarray(P), onsets[0].estimate.time)
