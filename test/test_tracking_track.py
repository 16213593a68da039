"""Unit tests of the track lifecycle and the tracking data types."""

import math

import numpy as np
import pytest

from safe_legged_c3bf.perception.track import (
    Detection,
    ObstaclePlane,
    Track,
    TrackConfig,
    TrackStatus,
)


def det(x=1.0, y=0.0, z=0.5, **kw):
    return Detection(center=(x, y, z), semi_axes=(0.3, 0.2), **kw)


def test_confirmation_needs_n_hits_in_m_cycles():
    cfg = TrackConfig(confirm_hits=3, confirm_window=5)
    trk = Track(7, det(), 0.0, cfg)
    assert trk.status is TrackStatus.TENTATIVE
    trk.mark_missed()
    trk.update(det(), 0.1)
    assert trk.status is TrackStatus.TENTATIVE
    trk.mark_missed()
    trk.update(det(), 0.2)  # 3 hits in the last 5 cycles
    assert trk.status is TrackStatus.CONFIRMED


def test_sparse_hits_do_not_confirm():
    cfg = TrackConfig(confirm_hits=3, confirm_window=5, tentative_max_coast_time=10.0)
    trk = Track(1, det(), 0.0, cfg)
    for k in range(1, 20):
        for _ in range(3):
            trk.mark_missed()
        trk.update(det(), float(k))  # 1 hit every 4 cycles: at most 2 in any window of 5
    assert trk.status is TrackStatus.TENTATIVE


def test_confirmed_track_coasts_then_goes_stale_by_time():
    cfg = TrackConfig(confirm_hits=1, confirm_window=1, max_coast_time=0.5)
    trk = Track(1, det(), 0.0, cfg)
    assert trk.confirmed
    for k in range(1, 10):
        trk.mark_missed()
        assert trk.consecutive_misses == k
    assert not trk.is_stale(0.5)
    assert trk.is_stale(0.51)
    snap = trk.snapshot(0.3)
    assert snap.coasting and snap.consecutive_misses == 9
    assert snap.time_since_update == pytest.approx(0.3)


def test_tentative_track_goes_stale_sooner():
    cfg = TrackConfig(tentative_max_coast_time=0.2, max_coast_time=1.0)
    trk = Track(1, det(), 0.0, cfg)
    assert trk.is_stale(0.25)


def test_snapshot_fields_and_prediction():
    cfg = TrackConfig(confirm_hits=1, confirm_window=1)
    trk = Track(4, det(plane=ObstaclePlane.HORIZONTAL, orientation=0.3, extent=2.0), 0.0, cfg)
    for k in range(1, 31):
        trk.update(
            det(x=1.0 + 0.5 * k / 30, plane=ObstaclePlane.HORIZONTAL, orientation=0.3), k / 30
        )
    snap = trk.snapshot(1.0)
    later = trk.snapshot(2.0)
    assert snap.track_id == 4 and snap.id == "track_4"
    assert snap.plane is ObstaclePlane.HORIZONTAL
    assert snap.semi_axes == (0.3, 0.2) and snap.orientation == pytest.approx(0.3)
    assert snap.extent == math.inf  # the latest detection did not give one
    assert snap.center.shape == (3,) and snap.velocity.shape == (3,)
    assert snap.position_covariance.shape == (3, 3) and snap.velocity_covariance.shape == (3, 3)
    assert snap.hits == 31 and snap.age == pytest.approx(1.0)
    assert snap.velocity_estimated
    np.testing.assert_allclose(snap.velocity, [0.5, 0.0, 0.0], atol=1e-3)
    np.testing.assert_allclose(later.center, snap.center + snap.velocity, atol=1e-9)
    assert np.trace(later.position_covariance) > np.trace(snap.position_covariance)
    with pytest.raises(ValueError):
        snap.center[0] = 3.0  # snapshots are read-only


def test_velocity_flag_needs_hits():
    trk = Track(1, det(), 0.0, TrackConfig(velocity_min_hits=5))
    trk.update(det(), 0.03)
    assert not trk.snapshot(0.03).velocity_estimated


def test_detector_id_is_kept_and_adopted():
    trk = Track(3, det(id="person_1"), 0.0, TrackConfig())
    assert trk.id == "person_1"
    trk.update(det(), 0.1)  # anonymous detection keeps the identity
    assert trk.id == "person_1"
    anon = Track(5, det(), 0.0, TrackConfig())
    anon.update(det(id="box"), 0.1)
    assert anon.id == "box"


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"confirm_hits": 6, "confirm_window": 5}, "confirm_hits"),
        ({"confirm_window": 0}, "confirm_window"),
        ({"max_coast_time": 0.0}, "max_coast_time"),
        ({"measurement_std": float("nan")}, "measurement_std"),
        ({"accel_psd": -1.0}, "accel_psd"),
        ({"velocity_min_hits": 2.5}, "velocity_min_hits"),
    ],
)
def test_config_validation_names_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        TrackConfig(**kwargs)
