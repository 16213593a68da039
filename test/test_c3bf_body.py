"""Whole-body C3BF: offset-point kinematics (finite differences), the robots' covers (against
their URDF collision shapes), the row pairing and its fold, and the filter with a body."""

import numpy as np
import pybullet
import pytest

from safe_legged_c3bf.c3bf import (
    DEFAULT_V_EPS,
    FilterStatus,
    HolonomicHeightModel,
    HolonomicModel,
    Obstacles,
    Plane,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleLateralHeightModel,
    UnicycleLateralModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
    c3bf_value,
)
from safe_legged_c3bf.c3bf.body import (
    TOP_EXCESS,
    BodyPoint,
    RobotBody,
    cells_for_excess,
    cover_box,
    robot_body,
)
from safe_legged_c3bf.c3bf.body_rows import body_rows
from safe_legged_c3bf.c3bf.errors import InvalidInputError
from safe_legged_c3bf.c3bf.lie import PLANE_AXES, row_barrier_terms
from safe_legged_c3bf.c3bf.offset_kinematics import offset_point_kinematics

MODELS = [
    UnicycleModel(),
    UnicycleHeightModel(),
    HolonomicModel(),
    HolonomicHeightModel(),
    XZDoubleIntegratorModel(),
    UnicycleLateralModel(),
    UnicycleLateralHeightModel(),
]
RANGES = {"x": (-5, 5), "y": (-5, 5), "theta": (-np.pi, np.pi), "v": (-1.5, 3.0),
          "omega": (-2.0, 2.0), "z": (0.1, 0.6), "vz": (-1.0, 1.0), "vx": (-3, 3),
          "vy": (-3, 3), "v_l": (-1, 1)}


def _state(model, rng):
    lo = np.array([RANGES[s][0] for s in model.state_names])
    hi = np.array([RANGES[s][1] for s in model.state_names])
    return rng.uniform(lo, hi)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_offset_points_kinematics_match_finite_differences_of_f_and_g(model):
    """V = dP/dx f, dP/dx g = 0, dV/dx f = a_drift, dV/dx g = B, for points all around."""
    rng = np.random.default_rng(5)
    eps = 1e-6
    for _ in range(200):
        x = _state(model, rng)
        yaw = float(rng.uniform(-np.pi, np.pi)) if model.needs_yaw else None
        offsets = rng.uniform(-0.6, 0.6, (7, 3))
        kin = offset_point_kinematics(model, x, offsets, yaw)
        f, g = model.f(x, yaw), model.g(x, yaw)

        def d(direction, attr, x=x, yaw=yaw, offsets=offsets):
            a = getattr(offset_point_kinematics(model, x + eps * direction, offsets, yaw), attr)
            b = getattr(offset_point_kinematics(model, x - eps * direction, offsets, yaw), attr)
            return (a - b) / (2 * eps)

        np.testing.assert_allclose(d(f, "position"), kin.velocity, atol=1e-7)
        np.testing.assert_allclose(d(f, "velocity"), kin.accel_drift, atol=1e-7)
        for j in range(model.n_u):
            np.testing.assert_allclose(d(g[:, j], "position"), 0.0, atol=1e-7)
            np.testing.assert_allclose(d(g[:, j], "velocity"), kin.accel_input[:, :, j],
                                       atol=1e-7)


@pytest.mark.parametrize("l", [0.0, 0.1, 0.3])
def test_a_point_ahead_is_the_papers_body_point(l):  # noqa: E741 - the paper's symbol
    rng = np.random.default_rng(2)
    for cls in (UnicycleModel, UnicycleHeightModel):
        model = cls(offset=l)
        for _ in range(50):
            x = _state(model, rng)
            a = model.point_kinematics(x)
            b = offset_point_kinematics(cls(), x, [[l, 0.0, 0.0]])
            for ka, kb in zip(a, b, strict=True):
                np.testing.assert_allclose(kb[0], ka, atol=1e-15)


def _rows_h(model, x, yaw, body, obs):
    """h of every (point, obstacle) row at state ``x``."""
    r = body_rows(model, x, yaw, body, obs)
    axes = PLANE_AXES[r.obstacles.plane]
    P = np.take_along_axis(r.kin.position, axes, -1)
    V = np.take_along_axis(r.kin.velocity, axes, -1)
    return c3bf_value(r.obstacles.center - P, r.obstacles.velocity - V, r.obstacles.radius,
                      DEFAULT_V_EPS)


@pytest.mark.parametrize("model", [UnicycleHeightModel(), HolonomicHeightModel()],
                         ids=lambda m: type(m).__name__)
def test_row_lie_derivatives_match_finite_differences(model):
    """dh/dt of every (point, obstacle) row along f + g u, moving obstacles included."""
    rng = np.random.default_rng(9)
    body = robot_body("a1")
    filt = SafetyFilter(model, body=body)
    dt = 1e-6
    for _ in range(100):
        x = _state(model, rng)
        yaw = float(rng.uniform(-np.pi, np.pi)) if model.needs_yaw else None
        u = rng.uniform(-1, 1, model.n_u)
        obs = Obstacles.concatenate(
            Obstacles.vertical(rng.uniform(-5, 5, (2, 2)) + x[:2], rng.uniform(0.1, 0.4, 2),
                               rng.uniform(-1, 1, (2, 2))),
            Obstacles.horizontal([[x[0] + rng.uniform(-2, 2), rng.uniform(0.2, 0.8)]], [0.05],
                                 [[rng.uniform(-1, 1), 0.0]]),
        )
        rows = body_rows(model, x, yaw, filt.body, obs)
        t = row_barrier_terms(rows.kin, rows.obstacles.center, rows.obstacles.velocity,
                              rows.obstacles.radius, rows.obstacles.plane, DEFAULT_V_EPS)
        ok = t.clearance > 1e-3  # the cone is defined outside the circles
        x_dot = model.f(x, yaw) + model.g(x, yaw) @ u  # yaw: a parameter, held over the step
        fd = (_rows_h(model, x + dt * x_dot, yaw, filt.body, obs.advanced(dt))
              - _rows_h(model, x - dt * x_dot, yaw, filt.body, obs.advanced(-dt))) / (2 * dt)
        analytic = t.lf_h + t.lg_h @ u
        scale = 1.0 + np.abs(analytic)
        assert np.all(np.abs(fd - analytic)[ok] <= 1e-5 * scale[ok])


def _link_boxes(name):
    """Collision AABB corners of every link in base_link at the nominal standing posture."""
    from safe_legged_c3bf.sim.robots import load_robot

    c = pybullet.connect(pybullet.DIRECT)
    try:
        h = load_robot(c, name)
        com, q = pybullet.getBasePositionAndOrientation(h.body_id, physicsClientId=c)
        info = pybullet.getDynamicsInfo(h.body_id, -1, physicsClientId=c)
        inv = pybullet.invertTransform(info[3], info[4])
        base = np.array(pybullet.multiplyTransforms(com, q, inv[0], inv[1])[0])
        boxes = {}
        for link, li in [("base", -1), *h.link_ids.items()]:
            lo, hi = (np.array(v) - base for v in pybullet.getAABB(h.body_id, li,
                                                                   physicsClientId=c))
            if np.all(hi - lo > 1e-3):
                boxes[link] = (lo, hi)
        return boxes, float(base[2])
    finally:
        pybullet.disconnect(c)


def _covered(points, plane, samples):
    """Each sample (in-plane, base frame) is inside some circle of ``plane``."""
    centres = np.array([p.offset for p in points if p.plane is plane])[:, list(PLANE_AXES[plane])]
    radii = np.array([p.radius for p in points if p.plane is plane])
    d = np.linalg.norm(samples[:, None, :] - centres[None], axis=-1)
    return (d <= radii[None] + 1e-9).any(axis=1)


def _box_samples(lo, hi, axes, n=9):
    g = [np.linspace(lo[a], hi[a], n) for a in axes]
    return np.array(np.meshgrid(*g)).reshape(2, -1).T


@pytest.mark.parametrize("name", ["a1", "biped"])
def test_the_cover_holds_every_link_of_the_urdf_at_the_nominal_posture(name):
    body = robot_body(name)
    boxes, _ = _link_boxes(name)
    assert len(boxes) >= 5
    for link, (lo, hi) in boxes.items():
        for plane, axes in ((Plane.VERTICAL, (0, 1)), (Plane.HORIZONTAL, (0, 2))):
            inside = _covered(body.points, plane, _box_samples(lo, hi, axes))
            assert inside.all(), f"{name} {link} not covered in {plane.name}"


def test_the_a1_cover_holds_the_toes_at_their_trot_reach():
    body = robot_body("a1")
    toes = np.array([[sx * 0.28 + sx * 0.02, sy * 0.15 + sy * 0.02] for sx in (-1, 1)
                     for sy in (-1, 1)])
    assert _covered(body.points, Plane.VERTICAL, toes).all()


def test_the_cover_is_much_tighter_than_the_papers_circle():
    """The footprint circles stay within 0.21 m of the A1's axis; the old circle was 0.41 m."""
    body = robot_body("a1")
    for p in body.points_in(Plane.VERTICAL):
        assert abs(p.offset[1]) + p.radius < 0.21


@pytest.mark.parametrize(("name", "top"), [("a1", 0.058), ("biped", 0.231)])
def test_the_top_row_bulges_at_most_top_excess_above_the_body(name, top):
    """The highest x-z circle edge is within TOP_EXCESS of the trunk's (head's) top."""
    xz = robot_body(name).points_in(Plane.HORIZONTAL)
    highest = max(p.offset[2] + p.radius for p in xz)
    assert top <= highest <= top + TOP_EXCESS + 1e-9
    assert cells_for_excess(0.64, 0.116, 0.02) < cells_for_excess(0.64, 0.116)


def test_cover_box_and_validation():
    pts = cover_box((0.0, 1.0), (0.0, 0.2), 5, Plane.HORIZONTAL, "t", rows=2)
    assert len(pts) == 10 and all(p.plane is Plane.HORIZONTAL for p in pts)
    with pytest.raises(InvalidInputError):
        cover_box((1.0, 0.0), (0.0, 0.2), 2, Plane.VERTICAL, "bad")
    with pytest.raises(InvalidInputError):
        BodyPoint((0.0, 0.0, np.nan), 0.1, Plane.VERTICAL)
    with pytest.raises(InvalidInputError):
        BodyPoint((0.0, 0.0, 0.0), 0.0, Plane.VERTICAL)
    with pytest.raises(InvalidInputError):
        robot_body("hexapod")


def test_an_obstacle_without_points_of_its_plane_is_refused():
    body = RobotBody("flat", (BodyPoint((0, 0, 0), 0.2, Plane.VERTICAL),), 0.2)
    f = SafetyFilter(UnicycleHeightModel(), body=body)
    bar = Obstacles.horizontal([[2.0, 0.3]], [0.05])
    with pytest.raises(InvalidInputError, match="no point for HORIZONTAL"):
        f.filter(np.array([0, 0, 0, 0.5, 0, 0.3, 0]), [0, 0, 0], bar)


def _filter(method="auto"):
    lim = np.array([1.0, 4.0, 1.0])
    return SafetyFilter(UnicycleHeightModel(), gamma=1.0, u_min=-lim, u_max=lim,
                        body=robot_body("a1"), method=method)


def test_a_rear_point_is_protected_from_a_bar_while_the_trunk_rises():
    """Just past a bar above the rear half, rising is refused; the single point allows it."""
    x = np.array([0.0, 0.0, 0.0, 0.3, 0.0, 0.20, 0.0])
    bar = Obstacles.horizontal([[-0.15, 0.36]], [0.025])  # axis 0.36 m over the rear
    res = _filter().filter(x, [0.0, 0.0, 1.0], bar)
    assert res.u_safe[2] < 0.5 and res.status is not FilterStatus.INACTIVE
    point = SafetyFilter(UnicycleHeightModel(offset=0.1), gamma=1.0,
                         u_min=[-1, -4, -1], u_max=[1, 4, 1])
    bar_point = Obstacles.horizontal([[-0.15, 0.36]], [0.025 + 0.06])
    assert point.filter(x, [0.0, 0.0, 1.0], bar_point).status is FilterStatus.INACTIVE


def test_rows_and_fold_agree_with_osqp():
    rng = np.random.default_rng(4)
    fa, fq = _filter("auto"), _filter("qp")
    for _ in range(50):
        x = np.array([0, 0, rng.uniform(-0.3, 0.3), rng.uniform(0, 0.8), 0, 0.27, 0])
        obs = Obstacles.vertical(rng.uniform([1.0, -1.5], [3.0, 1.5], (4, 2)),
                                 rng.uniform(0.1, 0.4, 4), rng.uniform(-0.4, 0.4, (4, 2)))
        u_ref = np.array([1.0, rng.uniform(-1, 1), 0.0])
        a, q = fa.filter(x, u_ref, obs), fq.filter(x, u_ref, obs)
        assert a.status == q.status
        np.testing.assert_allclose(a.u_safe, q.u_safe, atol=1e-5)
        assert a.h.shape == (4,) and a.point.shape == (4,)
        assert set(a.point.tolist()) <= {0, 1, 2}


def test_directional_rows_match_finite_differences_and_stay_below_the_papers_h():
    """Below v_eps a row with a reference direction e uses h = <p + s e, v>: its Lie
    derivatives (e held) match finite differences, and it never exceeds the paper's h."""
    rng = np.random.default_rng(12)
    model, body = UnicycleHeightModel(), robot_body("a1")
    v_eps, dt = 0.05, 1e-6
    for _ in range(100):
        x = np.array([0, 0, rng.uniform(-1, 1), rng.uniform(-0.02, 0.02), rng.uniform(-0.05, 0.05),
                      0.28, 0.0])
        u = rng.uniform(-1, 1, 3)
        obs = Obstacles.vertical(rng.uniform([1.0, -1.5], [3.0, 1.5], (2, 2)), [0.3, 0.2])
        rows = body_rows(model, x, None, body, obs)
        e = rng.normal(size=(len(rows.obstacle), 2))
        e /= np.linalg.norm(e, axis=1)[:, None]
        o = rows.obstacles

        t = row_barrier_terms(rows.kin, o.center, o.velocity, o.radius, o.plane, v_eps, e)
        x_dot = model.f(x) + model.g(x) @ u
        ahead, behind = (
            row_barrier_terms(body_rows(model, xs, None, body, obs).kin, o.center, o.velocity,
                              o.radius, o.plane, v_eps, e).h
            for xs in (x + dt * x_dot, x - dt * x_dot)
        )
        fd = (ahead - behind) / (2 * dt)
        np.testing.assert_allclose(t.lf_h + t.lg_h @ u, fd, atol=1e-6)
        paper = row_barrier_terms(rows.kin, o.center, o.velocity, o.radius, o.plane, 0.0).h
        assert np.all(t.h <= paper + 1e-12)


def test_from_rest_the_body_may_start_outside_the_cone_but_not_into_it():
    lim = np.array([1.0, 4.0, 1.0])
    f = SafetyFilter(UnicycleHeightModel(), u_min=-lim, u_max=lim, body=robot_body("a1"))
    pillar = Obstacles.vertical([[1.7, 0.0]], [0.33])
    into = f.filter(np.array([0, 0, 0.0, 0, 0, 0.28, 0]), [0.8, 0, 0], pillar)
    assert into.u_safe[0] < 1e-9  # straight at it: refused
    aside = f.filter(np.array([0, 0, 0.6, 0, 0, 0.28, 0]), [0.8, 0, 0], pillar)
    assert aside.status is FilterStatus.INACTIVE  # 34 degrees off: outside every cone
