"""Unit tests of the constant-velocity Kalman filter."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safe_legged_c3bf.perception.kalman import (
    ConstantVelocityKalmanFilter,
    process_noise,
    transition_matrix,
)


def test_transition_and_process_noise_structure():
    F = transition_matrix(2, 0.5)
    np.testing.assert_allclose(F @ np.array([1.0, 2.0, 3.0, 4.0]), [2.5, 4.0, 3.0, 4.0])
    Q = process_noise(3, 0.1, 2.0)
    assert Q.shape == (6, 6)
    np.testing.assert_allclose(Q, Q.T)
    assert Q[0, 0] == pytest.approx(2.0 * 0.1**3 / 3)
    assert Q[0, 3] == pytest.approx(2.0 * 0.1**2 / 2)
    assert Q[3, 3] == pytest.approx(2.0 * 0.1)
    assert Q[0, 1] == 0.0
    # Backward steps still add noise (conservative).
    np.testing.assert_allclose(process_noise(3, -0.1, 2.0), Q)


def test_dimension_from_initial_position():
    kf2 = ConstantVelocityKalmanFilter([1.0, 2.0])
    kf3 = ConstantVelocityKalmanFilter([1.0, 2.0, 3.0])
    assert kf2.dim == 2 and kf2.state.shape == (4,)
    assert kf3.dim == 3 and kf3.covariance.shape == (6, 6)
    with pytest.raises(ValueError, match="2 or 3"):
        ConstantVelocityKalmanFilter([1.0])
    with pytest.raises(ValueError, match="finite"):
        ConstantVelocityKalmanFilter([1.0, math.nan])


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"accel_psd": -1.0}, "accel_psd"),
        ({"measurement_std": 0.0}, "measurement_std"),
        ({"measurement_std": math.inf}, "measurement_std"),
        ({"initial_velocity_std": -0.1}, "initial_velocity_std"),
    ],
)
def test_invalid_parameters_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        ConstantVelocityKalmanFilter([0.0, 0.0, 0.0], **kwargs)


def test_predict_moves_mean_and_grows_covariance():
    kf = ConstantVelocityKalmanFilter([0.0, 0.0, 0.0], 1.0, initial_velocity=[1.0, -2.0, 0.5])
    P0 = kf.covariance
    kf.predict(0.5)
    np.testing.assert_allclose(kf.position, [0.5, -1.0, 0.25])
    np.testing.assert_allclose(kf.velocity, [1.0, -2.0, 0.5])
    assert kf.time == pytest.approx(1.5)
    assert np.all(np.diag(kf.covariance) >= np.diag(P0))
    with pytest.raises(ValueError, match="dt"):
        kf.predict(-0.1)


def test_state_at_has_no_side_effect_and_extrapolates_both_ways():
    kf = ConstantVelocityKalmanFilter([1.0, 1.0, 0.0], 2.0, initial_velocity=[0.5, 0.0, 0.0])
    x_before, P_before = kf.state, kf.covariance
    x_future, P_future = kf.state_at(4.0)
    x_past, P_past = kf.state_at(1.0)
    np.testing.assert_allclose(kf.state, x_before)
    np.testing.assert_allclose(kf.covariance, P_before)
    np.testing.assert_allclose(x_future[:3], [2.0, 1.0, 0.0])
    np.testing.assert_allclose(x_past[:3], [0.5, 1.0, 0.0])
    assert P_future[0, 0] > P_before[0, 0]
    assert P_past[0, 0] > P_before[0, 0]
    x_now, P_now = kf.state_at(2.0)
    np.testing.assert_allclose(x_now, x_before)
    np.testing.assert_allclose(P_now, P_before)


def test_update_pulls_towards_measurement_and_shrinks_covariance():
    kf = ConstantVelocityKalmanFilter([0.0, 0.0], measurement_std=0.1)
    kf.predict(0.1)
    prior = kf.covariance
    nis = kf.update([0.2, 0.0])
    assert 0.0 < kf.position[0] < 0.2
    assert kf.covariance[0, 0] < prior[0, 0]
    assert nis == pytest.approx(0.2**2 / (prior[0, 0] + 0.01))
    assert kf.mahalanobis_sq(kf.position) == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="2 coordinates"):
        kf.update([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="finite"):
        kf.update([math.nan, 0.0])


def test_noise_free_constant_velocity_is_recovered():
    v = np.array([0.4, -0.3, 0.1])
    kf = ConstantVelocityKalmanFilter([0.0, 0.0, 0.0], 0.0)
    dt = 0.05
    for k in range(1, 60):
        kf.predict(dt)
        kf.update(v * k * dt)
    np.testing.assert_allclose(kf.velocity, v, atol=1e-3)


def test_converged_covariance_matches_empirical_error():
    """The filter's velocity variance is consistent with the error of a random-walk target."""
    rng = np.random.default_rng(3)
    q, sigma, dt = 0.05, 0.02, 1 / 30
    errors, variances = [], []
    for _ in range(40):
        p, v = np.zeros(2), np.zeros(2)
        kf = ConstantVelocityKalmanFilter(
            p + rng.normal(0, sigma, 2), accel_psd=q, measurement_std=sigma
        )
        for k in range(150):
            # Exact discretisation of the white-acceleration model.
            w = rng.multivariate_normal(np.zeros(4), process_noise(2, dt, q))
            p, v = p + v * dt + w[:2], v + w[2:]
            kf.predict(dt)
            kf.update(p + rng.normal(0, sigma, 2))
            if k >= 100:
                errors.append(kf.velocity[0] - v[0])
                variances.append(kf.velocity_covariance[0, 0])
    ratio = np.mean(np.square(errors)) / np.mean(variances)
    assert 0.7 < ratio < 1.4


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(0.0, 2.0),
            st.floats(-50.0, 50.0),
            st.floats(-50.0, 50.0),
            st.floats(-50.0, 50.0),
        ),
        min_size=1,
        max_size=20,
    )
)
def test_covariance_stays_symmetric_positive_definite(steps):
    kf = ConstantVelocityKalmanFilter([0.0, 0.0, 0.0], accel_psd=0.01, measurement_std=0.02)
    for dt, *z in steps:
        kf.predict(dt)
        kf.update(z)
        P = kf.covariance
        np.testing.assert_allclose(P, P.T, atol=1e-12)
        assert np.linalg.eigvalsh(P)[0] > 0.0
        assert np.all(np.isfinite(kf.state))
