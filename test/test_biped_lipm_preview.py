"""ZMP preview control on the cart-table model (Kajita 2003)."""

import numpy as np
import pytest

from safe_legged_c3bf.gait.biped.lipm_preview import (
    ZmpPreviewController,
    cart_table_matrices,
    preview_gains,
)

DT = 0.005


def footstep_zmp(times: np.ndarray, t0: float = 2.0, period: float = 0.52, ds: float = 0.12):
    """A walking ZMP reference: 0.08 m steps, +-0.1 m sway, linear double-support transfers."""
    tau = np.maximum(times - t0, 0.0)
    k = np.floor(tau / period)
    phase = tau - k * period
    x, y = 0.08 * k, 0.1 * (-1.0) ** k
    xp = 0.08 * np.maximum(k - 1, 0)
    yp = np.where(k == 0, 0.0, -y)
    a = np.clip(phase / ds, 0.0, 1.0)
    ref = np.stack([xp + (x - xp) * a, yp + (y - yp) * a], axis=1)
    ref[times < t0] = 0.0
    return ref


def test_cart_table_output_is_the_zmp():
    a, b, c = cart_table_matrices(DT, 0.6)
    assert a.shape == (3, 3) and b.shape == (3,)
    # p = x - z/g x''
    assert c @ np.array([0.1, 0.0, 9.81]) == pytest.approx(0.1 - 0.6)


def test_gains_are_consistent():
    gi, gx, gp = preview_gains(DT, 0.6, 1.6)
    assert gp.size == 320 and gi > 0
    # with a constant reference the preview and state gains cancel at equilibrium
    assert -gp.sum() == pytest.approx(gx[0], rel=0.01)
    # the preview weights fade out over the horizon
    assert abs(gp[-1]) < 0.01 * abs(gp[0])


def test_invalid_parameters_raise():
    with pytest.raises(ValueError):
        preview_gains(0.0, 0.6, 1.6)
    with pytest.raises(ValueError):
        preview_gains(DT, 0.6, 1.6, r=0.0)


def test_zmp_tracks_a_walking_reference_within_1cm():
    ctrl = ZmpPreviewController(DT, 0.6, horizon=1.6)
    ctrl.reset(np.zeros(2))
    n = ctrl.n_preview + 1
    times = np.arange(0.0, 12.0 + n * DT, DT)
    ref = footstep_zmp(times)
    errors, coms = [], []
    for k in range(int(10.0 / DT)):
        ctrl.step(ref[k : k + n])
        errors.append(ctrl.zmp - ref[k + 1])
        coms.append(ctrl.state[0].copy())
    errors = np.abs(np.array(errors))
    assert errors.max() < 0.01
    assert np.sqrt((errors**2).mean()) < 0.002
    # the CoM sways between the feet, not over them, and advances with the steps
    coms = np.array(coms)
    assert 0.02 < np.abs(coms[-200:, 1]).max() < 0.08
    assert coms[-1, 0] > 0.08 * 14


def test_dcm_follows_lipm_dynamics():
    ctrl = ZmpPreviewController(DT, 0.6)
    ctrl.reset(np.zeros(2))
    ref = np.tile([0.05, -0.02], (ctrl.n_preview + 1, 1))
    for _ in range(50):
        before_dcm, before_zmp = ctrl.dcm.copy(), ctrl.zmp.copy()
        ctrl.step(ref)
        # xi' = omega (xi - p), integrated over one sample
        rate = (ctrl.dcm - before_dcm) / DT
        expected = ctrl.omega * (0.5 * (before_dcm + ctrl.dcm) - 0.5 * (before_zmp + ctrl.zmp))
        np.testing.assert_allclose(rate, expected, rtol=0.01, atol=1e-3)


def test_short_reference_is_padded():
    ctrl = ZmpPreviewController(DT, 0.6)
    ctrl.reset(np.zeros(2))
    state = ctrl.step(np.array([[0.01, 0.0]]))
    assert state.shape == (3, 2) and np.all(np.isfinite(state))
