"""A detection's own position covariance weighs it in its track's filter (issue #19).

A range-sensor detector knows which directions it measures poorly: the unseen far side of a
cluster, the open end of a wall piece. Its centre jumps along them when the robot sees the
obstacle from elsewhere; weighed by the reported covariance those jumps must not become
speeds of a static obstacle, while what is measured well still follows a real motion.
"""

import math

import numpy as np
import pytest

from safe_legged_c3bf.perception.kalman import ConstantVelocityKalmanFilter, floored_covariance
from safe_legged_c3bf.perception.track import Detection, Track, TrackConfig
from safe_legged_c3bf.perception.tracker import (
    MultiObstacleTracker,
    RejectionReason,
    TrackerConfig,
    validate_detection,
)

RATE = 10.0  # Hz, the detector's


def det(x, y, cov=None):
    return Detection(center=(x, y, 0.5), semi_axes=(0.3, 0.3), position_covariance=cov)


def test_floored_covariance_makes_any_report_usable():
    assert np.allclose(floored_covariance(np.zeros((3, 3)), 0.02), 4e-4 * np.eye(3))
    bent = np.array([[1e-2, 2e-2, 0.0], [0.0, 1e-2, 0.0], [0.0, 0.0, -1e-6]])  # not symmetric
    R = floored_covariance(bent, 0.02)
    assert np.allclose(R, R.T) and np.linalg.eigvalsh(R).min() >= 4e-4 - 1e-12


def test_an_isotropic_covariance_is_the_same_update_as_the_measurement_std():
    a = ConstantVelocityKalmanFilter(np.zeros(3), 0.0, measurement_std=0.05)
    b = ConstantVelocityKalmanFilter(np.zeros(3), 0.0, measurement_std=0.05)
    for k in range(1, 6):
        z = np.array([0.1 * k, 0.0, 0.0])
        a.predict_to(k / RATE)
        b.predict_to(k / RATE)
        assert a.update(z) == pytest.approx(b.update(z, measurement_cov=0.0025 * np.eye(3)))
    assert np.allclose(a.covariance, b.covariance) and np.allclose(a.velocity, b.velocity)


def test_a_bad_covariance_for_the_filter_is_refused():
    kf = ConstantVelocityKalmanFilter(np.zeros(3), 0.0)
    with pytest.raises(ValueError, match="measurement_cov"):
        kf.update(np.zeros(3), measurement_cov=np.full((3, 3), math.nan))
    with pytest.raises(ValueError, match="measurement_cov"):
        kf.update(np.zeros(3), measurement_cov=np.eye(2))


def _static_with_jumps(cov, config):
    """Largest speed (m/s) of a static obstacle whose centre jumps 10 cm along x, 4 times."""
    rng = np.random.default_rng(3)
    trk = Track(1, det(4.0, 0.0, cov), 0.0, config)
    fastest = 0.0
    for k in range(1, 80):
        x = 4.0 + 0.10 * ((k // 20) % 2) + rng.normal(0.0, 0.01)
        trk.update(det(x, rng.normal(0.0, 0.01), cov), k / RATE)
        if trk.velocity_estimated():
            fastest = max(fastest, float(np.linalg.norm(trk.kf.velocity[:2])))
    return fastest


@pytest.mark.parametrize("maneuvers", [False, True], ids=["plain", "manoeuvre detector"])
def test_jumps_along_a_poorly_measured_axis_are_no_speed(maneuvers):
    """The detector reports 10 cm along x (its viewing direction), 2 cm across.

    The manoeuvre detector takes 10 cm jumps measured at 2 cm for starts (0.5 m/s); weighed
    by the reported 10 cm they are not. The plain filter's low process noise smooths them
    either way.
    """
    loose_x = np.diag([0.10**2, 0.02**2, 0.02**2])
    ignored = _static_with_jumps(loose_x, TrackConfig(maneuver_detection=maneuvers,
                                                      use_detection_covariance=False))
    weighed = _static_with_jumps(loose_x, TrackConfig(maneuver_detection=maneuvers,
                                                      use_detection_covariance=True))
    print(f"\nlargest phantom speed: {ignored:.3f} m/s ignoring the covariance, "
          f"{weighed:.3f} m/s weighing by it")
    assert weighed < 0.1 and weighed <= ignored
    if maneuvers:
        assert ignored > 0.3


def test_a_start_across_the_poorly_measured_axis_is_still_followed():
    """0.5 m/s along y, measured well (2 cm); x is loose: the speed is found as without it."""
    loose_x = np.diag([0.10**2, 0.02**2, 0.02**2])
    speeds = {}
    for use in (False, True):
        config = TrackConfig(use_detection_covariance=use)
        trk = Track(1, det(4.0, 0.0, loose_x), 0.0, config)
        for k in range(1, 60):
            t = k / RATE
            y = 0.0 if t < 3.0 else 0.5 * (t - 3.0)
            trk.update(det(4.0, y, loose_x), t)
        speeds[use] = float(trk.kf.velocity[1])
    assert speeds[True] == pytest.approx(0.5, abs=0.1)
    assert speeds[True] == pytest.approx(speeds[False], abs=0.05)


def test_the_tracker_refuses_a_malformed_or_non_finite_covariance():
    assert validate_detection(det(1.0, 0.0, np.eye(2))) is RejectionReason.MALFORMED
    bad = np.eye(3)
    bad[0, 1] = math.inf
    assert validate_detection(det(1.0, 0.0, bad)) is RejectionReason.NON_FINITE
    assert validate_detection(det(1.0, 0.0, np.zeros((3, 3)))) is None  # zero: unknown
    tracker = MultiObstacleTracker(TrackerConfig(track=TrackConfig(use_detection_covariance=True)))
    report = tracker.update([det(1.0, 0.0, bad), det(3.0, 0.0, np.zeros((3, 3)))], 0.0)
    assert report.accepted == 1
    assert tracker.rejection_counts["non_finite"] == 1
