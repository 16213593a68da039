"""Constant-velocity Kalman filter for one obstacle.

State ``x = [p, v]`` with ``p`` the position (2 or 3 coordinates, metres, odom frame) and
``v`` the velocity (m/s).  The motion model is the discretised continuous white-noise
acceleration model (Bar-Shalom, "Estimation with Applications to Tracking and Navigation",
section 6.2.2): for a time step ``dt``

    F = [[I, dt I], [0, I]]
    Q = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]]

where ``q`` is the power spectral density of the acceleration noise (m^2/s^3).  The sensor
measures the position only, ``z = p + w`` with ``w ~ N(0, sigma^2 I)``, or with the
measurement's own covariance ``R`` when the caller passes one (a detector that knows which
directions it measures poorly).

The filter keeps its own time stamp so that it can be predicted to absolute times, and it
offers side-effect free predictions (:meth:`ConstantVelocityKalmanFilter.state_at`) for
publishing tracks at an arbitrary time. :meth:`~ConstantVelocityKalmanFilter.snapshot` and
:meth:`~ConstantVelocityKalmanFilter.restore` save and set the whole estimate, so that recent
updates can be processed again under another hypothesis (the manoeuvre detector,
:mod:`safe_legged_c3bf.perception.maneuver`).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "ConstantVelocityKalmanFilter",
    "FilterState",
    "floored_covariance",
    "process_noise",
    "transition_matrix",
]


@dataclass(frozen=True, eq=False)
class FilterState:
    """A saved estimate: state ``x = [p, v]``, its covariance ``P`` and its time stamp (s)."""

    x: np.ndarray
    P: np.ndarray
    time: float


def _check_positive(name: str, value: float, allow_zero: bool = False) -> float:
    """Return ``value`` as float or raise ``ValueError`` naming ``name``."""
    value = float(value)
    if not math.isfinite(value) or value < 0.0 or (value == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {bound}, got {value!r}")
    return value


def floored_covariance(cov: np.ndarray, std_floor: float) -> np.ndarray:
    """Symmetric part of ``cov`` (m^2) with every eigenvalue raised to ``std_floor^2`` at least.

    A reported covariance may be zero (unknown), rank-deficient or slightly indefinite from
    rounding; the floor makes it a usable, positive definite measurement noise.
    """
    C = np.asarray(cov, dtype=float)
    C = 0.5 * (C + C.T)
    w, V = np.linalg.eigh(C)
    return (V * np.maximum(w, float(std_floor) ** 2)) @ V.T


def transition_matrix(dim: int, dt: float) -> np.ndarray:
    """Return the constant-velocity state transition matrix for ``dim`` coordinates."""
    eye = np.eye(dim)
    F = np.eye(2 * dim)
    F[:dim, dim:] = dt * eye
    return F


def process_noise(dim: int, dt: float, accel_psd: float) -> np.ndarray:
    """Return the white-acceleration process noise covariance for a step ``dt``.

    ``dt`` may be negative (backward extrapolation); its absolute value is used so that the
    covariance still grows, which is the conservative choice.
    """
    h = abs(dt)
    eye = np.eye(dim)
    Q = np.empty((2 * dim, 2 * dim))
    Q[:dim, :dim] = (h**3 / 3.0) * eye
    Q[:dim, dim:] = (h**2 / 2.0) * eye
    Q[dim:, :dim] = (h**2 / 2.0) * eye
    Q[dim:, dim:] = h * eye
    return accel_psd * Q


class ConstantVelocityKalmanFilter:
    """Constant-velocity Kalman filter with position measurements.

    Parameters
    ----------
    position:
        Initial position measurement (2 or 3 coordinates); sets the dimension.
    time:
        Time stamp of ``position`` (s).
    accel_psd:
        Process noise: white acceleration power spectral density ``q`` (m^2/s^3).
    measurement_std:
        Standard deviation of the position measurement noise, per axis (m).
    initial_velocity:
        Prior velocity mean (defaults to zero).
    initial_velocity_std:
        Prior velocity standard deviation per axis (m/s).  It should cover the fastest
        obstacle expected; the filter then converges like a growing-window least-squares fit.

    """

    def __init__(
        self,
        position: Sequence[float] | np.ndarray,
        time: float = 0.0,
        *,
        accel_psd: float = 0.001,
        measurement_std: float = 0.02,
        initial_velocity: Sequence[float] | np.ndarray | None = None,
        initial_velocity_std: float = 1.5,
    ) -> None:
        p = np.asarray(position, dtype=float).reshape(-1)
        if p.size not in (2, 3):
            raise ValueError(f"position must have 2 or 3 coordinates, got {p.size}")
        if not np.all(np.isfinite(p)):
            raise ValueError("position must be finite")
        if not math.isfinite(float(time)):
            raise ValueError("time must be finite")
        self._dim = int(p.size)
        self.accel_psd = accel_psd
        self.measurement_std = measurement_std
        v0_std = _check_positive("initial_velocity_std", initial_velocity_std)
        v0 = np.zeros(self._dim)
        if initial_velocity is not None:
            v0 = np.asarray(initial_velocity, dtype=float).reshape(-1)
            if v0.size != self._dim or not np.all(np.isfinite(v0)):
                raise ValueError("initial_velocity must be finite with the dimension of position")
        self._x = np.concatenate([p, v0])
        self._P = np.diag(
            np.concatenate(
                [np.full(self._dim, self._measurement_var), np.full(self._dim, v0_std**2)]
            )
        )
        self._time = float(time)

    # ------------------------------------------------------------------ properties
    @property
    def dim(self) -> int:
        """Number of position coordinates (2 or 3)."""
        return self._dim

    @property
    def time(self) -> float:
        """Time stamp of the current estimate (s)."""
        return self._time

    @property
    def accel_psd(self) -> float:
        """Current process noise spectral density ``q`` (m^2/s^3)."""
        return self._accel_psd

    @accel_psd.setter
    def accel_psd(self, value: float) -> None:
        self._accel_psd = _check_positive("accel_psd", value, allow_zero=True)

    @property
    def measurement_std(self) -> float:
        """Default measurement noise standard deviation (m)."""
        return math.sqrt(self._measurement_var)

    @measurement_std.setter
    def measurement_std(self, value: float) -> None:
        self._measurement_var = _check_positive("measurement_std", value) ** 2

    @property
    def state(self) -> np.ndarray:
        """Copy of the state vector ``[p, v]``."""
        return self._x.copy()

    @property
    def covariance(self) -> np.ndarray:
        """Copy of the state covariance."""
        return self._P.copy()

    @property
    def position(self) -> np.ndarray:
        """Copy of the position estimate."""
        return self._x[: self._dim].copy()

    @property
    def velocity(self) -> np.ndarray:
        """Copy of the velocity estimate."""
        return self._x[self._dim :].copy()

    @property
    def position_covariance(self) -> np.ndarray:
        """Copy of the position covariance block."""
        d = self._dim
        return self._P[:d, :d].copy()

    @property
    def velocity_covariance(self) -> np.ndarray:
        """Copy of the velocity covariance block."""
        d = self._dim
        return self._P[d:, d:].copy()

    # ------------------------------------------------------------------ save / set
    def copy(self) -> ConstantVelocityKalmanFilter:
        """An independent filter with the same estimate, time and noise parameters."""
        other = copy.copy(self)
        other._x = self._x.copy()
        other._P = self._P.copy()
        return other

    def snapshot(self) -> FilterState:
        """The current estimate (copies), for :meth:`restore`."""
        return FilterState(self._x.copy(), self._P.copy(), self._time)

    def restore(self, state: FilterState) -> None:
        """Set the estimate to ``state`` (same dimension; finite; symmetric covariance kept)."""
        x = np.asarray(state.x, dtype=float).reshape(-1)
        P = np.asarray(state.P, dtype=float)
        n = 2 * self._dim
        if x.shape != (n,) or P.shape != (n, n):
            raise ValueError(f"state must have {n} entries and covariance shape ({n}, {n})")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P)) and math.isfinite(state.time)):
            raise ValueError("state, covariance and time must be finite")
        self._x = x.copy()
        self._P = 0.5 * (P + P.T)
        self._time = float(state.time)

    def add_velocity_variance(self, variance: float, axes: Sequence[int]) -> None:
        """Add ``variance`` (m^2/s^2) to the velocity variance of each coordinate in ``axes``.

        Models an unknown change of velocity (per axis, independent) since the last update.
        """
        variance = _check_positive("variance", variance, allow_zero=True)
        for a in axes:
            if not 0 <= int(a) < self._dim:
                raise ValueError(f"axis {a!r} out of range for {self._dim} coordinates")
            self._P[self._dim + int(a), self._dim + int(a)] += variance

    # ------------------------------------------------------------------ prediction
    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(x, P)`` predicted to absolute time ``t`` without changing the filter.

        Times before :attr:`time` extrapolate the mean backwards; the covariance still grows
        with ``|t - time|`` (conservative).
        """
        return self.predicted(float(t) - self._time)

    def predicted(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(x, P)`` predicted ``dt`` seconds ahead without changing the filter."""
        dt = float(dt)
        if not math.isfinite(dt):
            raise ValueError("dt must be finite")
        if dt == 0.0:
            return self._x.copy(), self._P.copy()
        F = transition_matrix(self._dim, dt)
        x = F @ self._x
        P = F @ self._P @ F.T + process_noise(self._dim, dt, self._accel_psd)
        return x, 0.5 * (P + P.T)

    def predict(self, dt: float) -> None:
        """Propagate the estimate ``dt >= 0`` seconds forward."""
        dt = float(dt)
        if not math.isfinite(dt) or dt < 0.0:
            raise ValueError(f"dt must be finite and >= 0, got {dt!r}")
        self._x, self._P = self.predicted(dt)
        self._time += dt

    def predict_to(self, t: float) -> None:
        """Propagate the estimate to absolute time ``t`` (must not be in the past)."""
        self.predict(float(t) - self._time)

    # ------------------------------------------------------------------ update
    def _measurement_cov(
        self, measurement_std: float | None, measurement_cov: np.ndarray | None = None
    ) -> np.ndarray:
        """``R``: ``measurement_cov`` when given, else ``measurement_std^2 I`` (m^2)."""
        if measurement_cov is not None:
            R = np.asarray(measurement_cov, dtype=float)
            if R.shape != (self._dim, self._dim) or not np.all(np.isfinite(R)):
                raise ValueError(f"measurement_cov must be a finite {self._dim}-square matrix")
            return R
        var = (
            self._measurement_var
            if measurement_std is None
            else _check_positive("measurement_std", measurement_std) ** 2
        )
        return var * np.eye(self._dim)

    def innovation(
        self,
        z: Sequence[float] | np.ndarray,
        measurement_std: float | None = None,
        measurement_cov: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return the innovation ``y = z - H x`` and its covariance ``S`` (current state).

        ``measurement_cov`` (m^2, positive definite), when given, is the measurement's own
        covariance ``R`` instead of ``measurement_std^2 I``.
        """
        z = np.asarray(z, dtype=float).reshape(-1)
        if z.size != self._dim:
            raise ValueError(f"measurement must have {self._dim} coordinates, got {z.size}")
        d = self._dim
        y = z - self._x[:d]
        S = self._P[:d, :d] + self._measurement_cov(measurement_std, measurement_cov)
        return y, S

    def mahalanobis_sq(
        self, z: Sequence[float] | np.ndarray, measurement_std: float | None = None
    ) -> float:
        """Return the squared Mahalanobis distance of ``z`` to the current prediction."""
        y, S = self.innovation(z, measurement_std)
        return float(y @ np.linalg.solve(S, y))

    def update(
        self,
        z: Sequence[float] | np.ndarray,
        measurement_std: float | None = None,
        measurement_cov: np.ndarray | None = None,
    ) -> float:
        """Correct the estimate with position measurement ``z``.

        Uses the Joseph form for numerical robustness.  Returns the normalised innovation
        squared (NIS) of the measurement, which is chi-square distributed with ``dim``
        degrees of freedom when the filter is consistent.  ``measurement_cov``: as in
        :meth:`innovation`.
        """
        z = np.asarray(z, dtype=float).reshape(-1)
        if not np.all(np.isfinite(z)):
            raise ValueError("measurement must be finite")
        y, S = self.innovation(z, measurement_std, measurement_cov)
        d = self._dim
        PHt = self._P[:, :d]  # P H^T with H = [I 0]
        K = np.linalg.solve(S, PHt.T).T  # S is symmetric
        nis = float(y @ np.linalg.solve(S, y))
        self._x = self._x + K @ y
        IKH = np.eye(2 * d)
        IKH[:, :d] -= K
        R = self._measurement_cov(measurement_std, measurement_cov)
        P = IKH @ self._P @ IKH.T + K @ R @ K.T
        self._P = 0.5 * (P + P.T)
        return nis
