"""Manoeuvre detection: obstacles that start, stop or turn, and static ones that must not move.

Simulated detections of one obstacle (anonymous, 10 Hz unless said otherwise, Gaussian centre
noise per axis) go through the multi-obstacle tracker with its default parameters. The
figure of merit of a manoeuvre is its *settling time*: from the true change of velocity to the
first frame from which the published planar velocity stays within 0.15 m/s of the truth (and
``velocity_estimated`` stays true). Run with ``-s`` to see the numbers.
"""

import math

import numpy as np
import pytest
from scipy.stats import chi2

from safe_legged_c3bf.perception.kalman import ConstantVelocityKalmanFilter
from safe_legged_c3bf.perception.maneuver import ManeuverDetector, in_plane_terms
from safe_legged_c3bf.perception.track import (
    Detection,
    ObstaclePlane,
    Track,
    TrackConfig,
    plane_axes,
)
from safe_legged_c3bf.perception.tracker import MultiObstacleTracker, TrackerConfig

TOLERANCE = 0.15  # m/s
SWITCH = 6.0  # s: the obstacle changes its velocity here (a detection time)
PLAIN = TrackerConfig(track=TrackConfig(maneuver_detection=False))


def run(kind, seed, *, rate=10.0, noise=0.02, duration=8.0, speed=0.5, outlier_rate=0.0,
        outlier=0.10, z_noise=None, config=None):
    """Track one obstacle; return the tracker and rows (t, planar v estimate, truth, flag).

    ``kind``: "static", "start" (standing, then ``speed`` from SWITCH), "stop" (the reverse)
    or "turn" (``speed`` turned by 90 degrees at SWITCH); the heading is random per seed.
    """
    rng = np.random.default_rng(seed)
    heading = rng.uniform(0.0, 2.0 * math.pi)
    u = np.array([math.cos(heading), math.sin(heading), 0.0])
    w = np.array([-u[1], u[0], 0.0])
    p0 = np.array([4.0, -2.0, 0.8])
    tracker = MultiObstacleTracker(config)
    rows = []
    for k in range(int(round(duration * rate)) + 1):
        t = k / rate
        before, after = min(t, SWITCH), max(t - SWITCH, 0.0)
        moving = speed * u
        if kind == "static":
            p, v = p0, np.zeros(3)
        elif kind == "start":
            p, v = p0 + moving * after, moving if t >= SWITCH else np.zeros(3)
        elif kind == "stop":
            p, v = p0 + moving * before, np.zeros(3) if t >= SWITCH else moving
        else:  # turn
            p = p0 + moving * before + speed * w * after
            v = speed * w if t >= SWITCH else moving
        z = p + rng.normal(0.0, noise, 3)
        if z_noise is not None:
            z[2] = p[2] + rng.normal(0.0, z_noise)
        if outlier_rate and rng.random() < outlier_rate:
            a = rng.uniform(0.0, 2.0 * math.pi)
            z[:2] += outlier * np.array([math.cos(a), math.sin(a)])
        tracker.update([Detection(z, (0.25, 0.25))], t)
        obstacles = tracker.tracks_at(t)
        if obstacles:
            o = obstacles[0]
            rows.append((t, o.velocity[:2].copy(), v[:2].copy(), o.velocity_estimated))
    return tracker, rows


def settling_time(rows):
    """s from SWITCH to the frame from which the estimate stays within TOLERANCE."""
    late = [r for r in rows if r[0] >= SWITCH - 1e-9]
    bad = [i for i, (_, ve, vt, ok) in enumerate(late)
           if np.linalg.norm(ve - vt) >= TOLERANCE or not ok]
    if not bad:
        return 0.0
    return late[bad[-1] + 1][0] - SWITCH if bad[-1] + 1 < len(late) else math.inf


def settling_times(kind, seeds=120, **kw):
    return np.array([settling_time(run(kind, seed, **kw)[1]) for seed in range(seeds)])


def describe(label, times):
    print(f"\n{label}: settling time median {np.median(times):.2f} s, within 0.3 s "
          f"{np.mean(times <= 0.3 + 1e-9):.0%}, within 0.4 s {np.mean(times <= 0.4 + 1e-9):.0%},"
          f" max {times.max():.2f} s")


@pytest.mark.parametrize("kind", ["start", "stop", "turn"])
def test_a_manoeuvre_is_followed_within_a_few_frames(kind):
    """0.5 m/s start / stop / 90 degree turn, 2 cm noise, 10 Hz, 120 headings and noises.

    Three frames after the change the test has seen 5, 10 and 15 cm of displacement against
    2 cm of noise: most runs are within 0.15 m/s by then, all within 0.7 s. The plain Kalman
    filter needs about 1.5 s.
    """
    times = settling_times(kind)
    describe(f"{kind}, manoeuvre detector", times)
    assert np.median(times) <= 0.3 + 1e-9
    assert np.mean(times <= 0.3 + 1e-9) >= 0.7
    assert np.mean(times <= 0.4 + 1e-9) >= 0.8
    assert times.max() <= 0.7 + 1e-9
    plain = settling_times(kind, seeds=5, config=PLAIN)
    describe(f"{kind}, plain Kalman filter", plain)
    assert plain.min() >= 1.0


def test_a_walker_start_is_followed_within_three_frames_at_twenty_hertz():
    times = settling_times("start", rate=20.0)
    describe("start, 20 Hz", times)
    assert np.median(times) <= 0.25 + 1e-9
    assert times.max() <= 0.7 + 1e-9


@pytest.mark.parametrize(
    ("label", "kw"),
    [
        ("2 cm noise", {"noise": 0.02}),
        ("3 cm jitter, 3 % 10 cm outliers", {"noise": 0.03, "outlier_rate": 0.03}),
        ("2 cm noise, 8 cm along the extrusion axis (z)", {"noise": 0.02, "z_noise": 0.08}),
    ],
)
def test_a_static_obstacle_does_not_look_like_it_moves(label, kw):
    """60 s of a static obstacle, 5 seeds: no manoeuvre, speed well below 0.1 m/s.

    The measurement noise stays the configured 2 cm, also when the detections jitter more:
    the detector's thresholds follow the track's own NIS level. The first 2 s (the velocity
    converging from its prior, as before) are left out.
    """
    top, manoeuvres = 0.0, 0
    for seed in range(5):
        tracker, rows = run("static", 100 + seed, duration=60.0, **kw)
        top = max(top, max(np.linalg.norm(ve) for t, ve, _, _ in rows if t >= 2.0))
        manoeuvres += tracker.maneuver_count
    print(f"\nstatic, {label}: largest speed {top:.3f} m/s, manoeuvres {manoeuvres}")
    assert manoeuvres == 0
    assert top < 0.06


@pytest.mark.parametrize("size", [0.15, 0.3])
def test_one_outlying_detection_is_not_a_manoeuvre(size):
    tracker = MultiObstacleTracker()
    rng = np.random.default_rng(4)
    p = np.array([3.0, 1.0, 0.5])
    top = 0.0
    for k in range(100):
        t = k / 10
        z = p + rng.normal(0.0, 0.02, 3)
        if k == 50:
            z[:2] += size * np.array([0.6, 0.8])
        tracker.update([Detection(z, (0.25, 0.25))], t)
        if t >= 2.0:
            top = max(top, tracker.tracks_at(t)[0].speed)
    assert tracker.maneuver_count == 0
    assert top < 0.1


def test_the_velocity_stays_estimated_through_a_correction():
    """A correction widens the velocity covariance; the published velocity stays ESTIMATED."""
    for seed in range(10):
        tracker, rows = run("turn", seed)
        assert tracker.maneuver_count >= 1
        assert all(ok for t, _, _, ok in rows if t >= 1.0)


def test_without_detection_the_track_is_a_plain_kalman_filter():
    cfg = TrackConfig(maneuver_detection=False)
    a = Track(1, Detection((1.0, 0.0, 0.5), (0.3, 0.3)), 0.0, cfg)
    kf = ConstantVelocityKalmanFilter(
        [1.0, 0.0, 0.5], 0.0, accel_psd=cfg.accel_psd, measurement_std=cfg.measurement_std,
        initial_velocity_std=cfg.initial_velocity_std,
    )
    for k in range(1, 40):
        z = [1.0 + (0.5 * (k - 20) / 10 if k > 20 else 0.0), 0.0, 0.5]
        a.update(Detection(z, (0.3, 0.3)), k / 10)
        kf.predict_to(k / 10)
        kf.update(z)
    assert a.maneuvers == 0
    np.testing.assert_allclose(a.kf.state, kf.state)


# --------------------------------------------------------------------------- the detector


def test_thresholds_are_chi_square_quantiles():
    det = ManeuverDetector(false_alarm=1e-6, fit_probability=0.01)
    assert det.threshold == pytest.approx(chi2.isf(1e-6, 2))
    assert det.threshold == pytest.approx(27.63, abs=0.01)
    assert det.fit_threshold == pytest.approx(9.21, abs=0.01)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"false_alarm": 0.0}, "false_alarm"),
        ({"false_alarm": 1.0}, "false_alarm"),
        ({"fit_probability": math.nan}, "fit_probability"),
        ({"min_updates": 6, "window": 5}, "min_updates"),
        ({"min_updates": 0}, "min_updates"),
        ({"velocity_std": 0.0}, "velocity_std"),
        ({"noise_window": -1}, "noise_window"),
        ({"noise_scale_min": 0.0}, "noise_scale_min"),
        ({"noise_scale_min": 1.5}, "noise_scale_min"),
        ({"noise_scale_min": math.inf}, "noise_scale_min"),
    ],
)
def test_detector_rejects_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        ManeuverDetector(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"maneuver_false_alarm": 0.0}, "maneuver_false_alarm"),
        ({"maneuver_fit_probability": 1.5}, "maneuver_fit_probability"),
        ({"maneuver_window": 2, "maneuver_min_updates": 3}, "maneuver_min_updates"),
        ({"maneuver_velocity_std": -1.0}, "maneuver_velocity_std"),
        ({"maneuver_noise_window": -1}, "maneuver_noise_window"),
        ({"maneuver_noise_scale_min": 0.0}, "maneuver_noise_scale_min"),
        ({"maneuver_noise_scale_min": 1.01}, "maneuver_noise_scale_min"),
        ({"maneuver_detection": "yes"}, "maneuver_detection"),
    ],
)
def test_track_config_validates_the_maneuver_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        TrackConfig(**kwargs)


def test_in_plane_terms_use_the_plane_coordinates_only():
    y = np.array([0.1, 0.0, 5.0])
    S = np.diag([0.01, 0.04, 0.01])
    nis, logdet = in_plane_terms(y, S, (0, 1))
    assert nis == pytest.approx(1.0)
    assert logdet == pytest.approx(math.log(0.01 * 0.04))
    assert in_plane_terms(y, S, (0, 2))[0] == pytest.approx(1.0 + 2500.0)
    assert plane_axes(ObstaclePlane.VERTICAL) == (0, 1)
    assert plane_axes(ObstaclePlane.HORIZONTAL) == (0, 2)


def test_a_moving_bar_is_tested_in_its_x_z_plane():
    """A horizontal bar starting to move up (z) is a manoeuvre; a vertical obstacle's z is not."""
    for plane, expect in ((ObstaclePlane.HORIZONTAL, 1), (ObstaclePlane.VERTICAL, 0)):
        rng = np.random.default_rng(2)
        tracker = MultiObstacleTracker()
        for k in range(90):
            t = k / 10
            z = np.array([3.0, 0.0, 0.6 + 0.5 * max(t - SWITCH, 0.0)]) + rng.normal(0, 0.02, 3)
            tracker.update([Detection(z, (1.0, 0.05), plane=plane)], t)
        assert tracker.maneuver_count == expect, plane


def test_noise_scale_follows_the_detection_jitter():
    """Detections noisier than measurement_std raise the thresholds by about the NIS ratio."""
    scales = {}
    for noise in (0.02, 0.04):
        rng = np.random.default_rng(1)
        trk = Track(1, Detection((2.0, 0.0, 0.5), (0.3, 0.3)), 0.0, TrackConfig())
        for k in range(1, 200):
            trk.update(Detection(np.array([2.0, 0.0, 0.5]) + rng.normal(0, noise, 3),
                                 (0.3, 0.3)), k / 10)
        scales[noise] = trk._maneuver.noise_scale
    assert scales[0.02] < 1.3
    assert 2.5 < scales[0.04] < 5.5


@pytest.mark.parametrize(
    ("floor", "low", "high"), [(1.0, 1.0, 1.0), (0.1, 0.1, 0.1), (0.01, 0.01, 0.08)]
)
def test_noise_scale_falls_to_its_floor_for_steady_detections(floor, low, high):
    """3 mm jitter against the configured 2 cm: the NIS median is a few hundredths of the
    chi-square one; the scale follows it down to ``maneuver_noise_scale_min``."""
    rng = np.random.default_rng(3)
    trk = Track(1, Detection((2.0, 0.0, 0.5), (0.3, 0.3)), 0.0,
                TrackConfig(maneuver_noise_scale_min=floor))
    for k in range(1, 200):
        trk.update(Detection(np.array([2.0, 0.0, 0.5]) + rng.normal(0, 0.003, 3), (0.3, 0.3)),
                   k / 10)
    assert low - 1e-12 <= trk._maneuver.noise_scale <= high + 1e-12


STEADY = TrackerConfig(track=TrackConfig(maneuver_noise_scale_min=0.1))


def test_a_slow_start_of_a_steadily_detected_obstacle_is_found_within_three_frames():
    """A walker standing in full view (3 mm jitter), then 0.24 m/s (random biped seed 11's),
    40 headings: with the thresholds following the measured noise (floor 0.1) its velocity is
    within 0.15 m/s after 0.2 s median, 0.3 s at most; with the configured 2 cm noise only
    after 0.5 s (the walker has moved 12 cm)."""
    kw = {"noise": 0.003, "speed": 0.24, "seeds": 40}
    steady = settling_times("start", config=STEADY, **kw)
    describe("0.24 m/s start, 3 mm jitter, floor 0.1", steady)
    assert np.median(steady) <= 0.2 + 1e-9
    assert steady.max() <= 0.3 + 1e-9
    configured = settling_times("start", **kw)
    describe("0.24 m/s start, 3 mm jitter, thresholds not lowered", configured)
    assert np.median(configured) >= 0.5 - 1e-9


@pytest.mark.parametrize(
    ("label", "kw"),
    [
        ("3 mm jitter", {"noise": 0.003}),
        ("3 mm jitter, 3 % 10 cm outliers", {"noise": 0.003, "outlier_rate": 0.03}),
        ("1 cm jitter", {"noise": 0.01}),
    ],
)
def test_lowered_thresholds_do_not_make_a_static_obstacle_move(label, kw):
    """60 s of a static obstacle, 5 seeds, thresholds following the measured noise (floor 0.1):
    no manoeuvre, speed well below 0.1 m/s."""
    top, manoeuvres = 0.0, 0
    for seed in range(5):
        tracker, rows = run("static", 100 + seed, duration=60.0, config=STEADY, **kw)
        top = max(top, max(np.linalg.norm(ve) for t, ve, _, _ in rows if t >= 2.0))
        manoeuvres += tracker.maneuver_count
    print(f"\nstatic, floor 0.1, {label}: largest speed {top:.3f} m/s, manoeuvres {manoeuvres}")
    assert manoeuvres == 0
    assert top < 0.06


def run_steps(seed, *, jump=0.08, every=6.0, duration=30.0, rate=10.0, noise=0.02):
    """A static obstacle whose detected centre jumps by ``jump`` (m, random direction) every
    ``every`` s and stays there, as a cluster seen from another side does; return the tracker
    and the largest estimated planar speed (m/s)."""
    rng = np.random.default_rng(seed)
    offset = np.zeros(3)
    tracker = MultiObstacleTracker()
    fastest = 0.0
    for k in range(int(round(duration * rate)) + 1):
        t = k / rate
        if k and k % int(round(every * rate)) == 0:
            a = rng.uniform(0.0, 2.0 * math.pi)
            offset = offset + jump * np.array([math.cos(a), math.sin(a), 0.0])
        z = np.array([4.0, -2.0, 0.8]) + offset + rng.normal(0.0, noise, 3)
        tracker.update([Detection(z, (0.25, 0.25))], t)
        for o in tracker.tracks_at(t):
            fastest = max(fastest, float(np.linalg.norm(o.velocity[:2])))
    return tracker, fastest


@pytest.mark.xfail(strict=True, reason="#19: a jump of a detected centre (a cluster seen from "
                   "another side) is taken for a start: 8 cm jumps give speeds up to 0.67 m/s. "
                   "Tried: a position-step hypothesis beside the velocity one; at 10 Hz with 2 cm "
                   "noise three updates do not tell a step from a start without delaying starts")
def test_a_jump_of_the_detected_centre_is_not_a_manoeuvre():
    """8 cm jumps of a static obstacle's detected centre (2 cm noise, 10 Hz, 4 jumps, 20 seeds)
    are no manoeuvre and give no speed near a walker's (0.15 m/s, the settling tolerance)."""
    speeds, maneuvers = [], 0
    for seed in range(20):
        tracker, fastest = run_steps(seed)
        speeds.append(fastest)
        maneuvers += tracker.maneuver_count
    print(f"\n8 cm steps: largest speed {max(speeds):.3f} m/s (median of runs "
          f"{np.median(speeds):.3f}), manoeuvres {maneuvers}")
    assert maneuvers == 0
    assert max(speeds) < 0.15
