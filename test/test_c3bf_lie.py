"""Analytic h, Lf h, Lg h of every model against central finite differences.

The Lie derivatives are taken w.r.t. the FULL model state (plus the obstacle's constant-velocity
motion for Lf). Each model is checked on 10,000 random states (vectorised), including fast
obstacles, small offsets l, near-tangent cones (||p_rel|| just above r) and tiny ||v_rel||.
"""

import numpy as np
import pytest

from safe_legged_c3bf.c3bf import (
    DEFAULT_V_EPS,
    HolonomicHeightModel,
    HolonomicModel,
    Obstacles,
    Plane,
    UnicycleHeightModel,
    UnicycleLateralHeightModel,
    UnicycleLateralModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
    c3bf_gradient,
    c3bf_lie_derivatives,
    c3bf_value,
)
from safe_legged_c3bf.c3bf.lie import PLANE_AXES
from safe_legged_c3bf.c3bf.rows import PointRows

N = 10_000
N_FILTER = 3_000  # states checked through the filter's own rows (one call each)
RTOL = 1e-6

MODELS = [
    UnicycleModel(offset=0.0),
    UnicycleModel(offset=1e-3),
    UnicycleModel(offset=0.25),
    XZDoubleIntegratorModel(),
    HolonomicModel(),
    UnicycleHeightModel(offset=0.0),
    UnicycleHeightModel(offset=2e-3),
    UnicycleHeightModel(offset=0.3),
    HolonomicHeightModel(),
    UnicycleLateralModel(offset=0.0),
    UnicycleLateralModel(offset=0.25),
    UnicycleLateralHeightModel(offset=0.0),
    UnicycleLateralHeightModel(offset=0.3),
]

RANGES = {
    "x": (-10, 10),
    "y": (-10, 10),
    "theta": (-np.pi, np.pi),
    "v": (-1.5, 3.0),
    "omega": (-2.0, 2.0),
    "z": (0.1, 0.6),
    "vz": (-1.0, 1.0),
    "vx": (-3.0, 3.0),
    "vy": (-3.0, 3.0),
    "v_l": (-1.0, 1.0),
}


def random_states(model, rng, n=N):
    lo = np.array([RANGES[s][0] for s in model.state_names])
    hi = np.array([RANGES[s][1] for s in model.state_names])
    return rng.uniform(lo, hi, size=(n, model.n_x))


def random_scene(model, rng, n=N):
    """States, yaw, and one obstacle per state with prescribed p_rel and varied speeds."""
    X = random_states(model, rng, n)
    yaw = rng.uniform(-np.pi, np.pi, n) if model.needs_yaw else None
    planes = np.array(sorted(int(p) for p in model.planes))
    plane = planes[rng.integers(0, len(planes), n)]
    kin = model.point_kinematics(X, yaw)
    axes = PLANE_AXES[plane]
    P = np.take_along_axis(kin.position, axes, -1)
    V = np.take_along_axis(kin.velocity, axes, -1)
    r = rng.uniform(0.2, 1.5, n)
    # ||p_rel|| = r (1 + d), d log-uniform down to 1e-5: near-tangent cones included.
    d = 10.0 ** rng.uniform(-5, 1, n)
    ang = rng.uniform(-np.pi, np.pi, n)
    p_rel = (r * (1 + d))[:, None] * np.stack([np.cos(ang), np.sin(ang)], -1)
    # Obstacle velocities: static, moderate, fast (up to 15 m/s), and some with v_rel ~ 0.
    kind = rng.integers(0, 4, n)
    speed = np.select([kind == 0, kind == 1, kind == 2], [0.0, 2.0, 15.0], 0.0)
    cv = speed[:, None] * rng.uniform(-1, 1, (n, 2))
    tiny = kind == 3
    cv[tiny] = V[tiny] + 10.0 ** rng.uniform(-8, -0.5, (tiny.sum(), 1)) * rng.normal(
        size=(tiny.sum(), 2)
    )
    c = P + p_rel
    return X, yaw, c, cv, r, plane


def h_of(model, X, yaw, c, cv, r, plane, v_eps):
    kin = model.point_kinematics(X, yaw)
    axes = PLANE_AXES[plane]
    P = np.take_along_axis(kin.position, axes, -1)
    V = np.take_along_axis(kin.velocity, axes, -1)
    return c3bf_value(c - P, cv - V, r, v_eps)


def filter_terms(model, X, yaw, c, cv, r, plane, v_eps):
    """``h``, ``Lf h``, ``Lg h`` the way the filter computes them: one state at a time, the
    rows of ``rows.PointRows`` (gated as in ``fast_path``, else every clamp and blend)."""
    h, lf, lg = np.empty(len(X)), np.empty(len(X)), np.empty((len(X), model.n_u))
    gated = 0
    for i in range(len(X)):
        point = PointRows(Obstacles(c[i], cv[i], r[i], plane[i]), 0.0, v_eps, model.n_u)
        kin = model.point_kinematics_tuple(X[i].tolist(), None if yaw is None else yaw[i])
        Y = point.products(kin)
        t = point.rows(Y, v_eps, point.gate)
        gated += t is not None
        t = t or point.rows(Y, v_eps)
        h[i], lf[i], lg[i] = t.h[0], t.rows[0, 0], t.rows[1:, 0]
    assert gated > len(X) // 2
    return h, lf, lg


@pytest.mark.parametrize("path", ["batched", "filter"])
@pytest.mark.parametrize("v_eps", [DEFAULT_V_EPS, 0.0])
@pytest.mark.parametrize("model", MODELS, ids=lambda m: repr(m))
def test_lie_derivatives_match_central_differences(model, v_eps, path):
    rng = np.random.default_rng(12345)
    X, yaw, c, cv, r, plane = random_scene(model, rng)
    if path == "filter":
        X, c, cv, r, plane = X[:N_FILTER], c[:N_FILTER], cv[:N_FILTER], r[:N_FILTER], \
            plane[:N_FILTER]
        yaw = None if yaw is None else yaw[:N_FILTER]
    terms = c3bf_lie_derivatives(
        model, X, c[:, None], cv[:, None], r[:, None], plane[:, None], yaw=yaw, v_eps=v_eps
    )
    h, lf, lg = terms.h[:, 0], terms.lf_h[:, 0], terms.lg_h[:, 0]
    if path == "filter":
        h, lf, lg = filter_terms(model, X, yaw, c, cv, r, plane, v_eps)
    np.testing.assert_allclose(h, h_of(model, X, yaw, c, cv, r, plane, v_eps), rtol=1e-12,
                               atol=1e-12)
    if v_eps == 0.0:
        # The paper's exact h is not differentiable at v_rel = 0: skip near-zero v_rel.
        keep = np.linalg.norm(terms.v_rel[:, 0], axis=-1) > 1e-3
    else:
        keep = np.ones(len(h), bool)

    f = model.f(X, yaw)
    g = model.g(X, yaw)
    kin = model.point_kinematics(X, yaw)
    axes = PLANE_AXES[plane]
    A = np.take_along_axis(kin.accel_drift, axes, -1)
    B = np.take_along_axis(kin.accel_input, axes[..., None], -2)
    p_rel, v_rel = terms.p_rel[:, 0], terms.v_rel[:, 0]
    p_n = np.linalg.norm(p_rel, axis=-1)
    # Curvature scales of h: s^2/|p| in p (cone tangent) and sqrt(|v|^2 + eps^2) in v.
    p_scale = terms.clearance[:, 0] / p_n
    v_scale = np.sqrt((v_rel**2).sum(-1) + v_eps**2)
    kappa = 1e-3

    def step_for(p_rate, v_rate):
        rate = np.maximum(p_rate / p_scale, v_rate / np.maximum(v_scale, 1e-300))
        return kappa / np.maximum(rate, 1.0)

    def fd(direction, obstacle_rate, step):
        """4th-order central difference of h along (direction, obstacle_rate)."""
        def hh(k):
            return h_of(model, X + (k * step)[:, None] * direction, yaw,
                        c + (k * step)[:, None] * obstacle_rate, cv, r, plane, v_eps)
        return (-hh(2) + 8 * hh(1) - 8 * hh(-1) + hh(-2)) / (12 * step)

    # Magnitude of the summed terms, to make the comparison relative where terms cancel.
    _, dh_dp, dh_dv, _ = c3bf_gradient(p_rel, v_rel, r, v_eps)
    lf_scale = np.abs(dh_dp * v_rel).sum(-1) + np.abs(dh_dv * A).sum(-1)
    # Floating-point noise of the difference quotient: ~1e-14 |h terms| / step.
    roundoff = 1e-14 * (np.abs(h) + p_n * v_scale + terms.clearance[:, 0] ** 0.5 * v_scale)
    step = step_for(np.linalg.norm(v_rel, axis=-1), np.linalg.norm(A, axis=-1))
    lf_fd = fd(f, cv, step)
    err = np.abs(lf - lf_fd)[keep]
    bound = (RTOL * (np.abs(lf) + lf_scale) + roundoff / step)[keep]
    assert np.all(err <= bound), f"Lf h: worst ratio {np.max(err / bound):.3g}"
    for j in range(model.n_u):
        Bj = B[..., j]
        step = step_for(np.zeros(len(X)), np.linalg.norm(Bj, axis=-1) + 1e-300)
        lg_fd = fd(g[..., j], np.zeros_like(cv), step)
        scale = np.abs(dh_dv * Bj).sum(-1)
        err = np.abs(lg[:, j] - lg_fd)[keep]
        bound = (RTOL * (np.abs(lg[:, j]) + scale) + roundoff / step)[keep]
        assert np.all(err <= bound), f"Lg h[{j}]: worst ratio {np.max(err / bound):.3g}"


@pytest.mark.parametrize("model", MODELS, ids=lambda m: repr(m))
def test_body_point_kinematics_consistent_with_f_and_g(model):
    """V = dP/dx f, dP/dx g = 0, dV/dx f = a_drift, dV/dx g = B (central differences)."""
    rng = np.random.default_rng(7)
    X = random_states(model, rng, 2000)
    yaw = rng.uniform(-np.pi, np.pi, 2000) if model.needs_yaw else None
    kin = model.point_kinematics(X, yaw)
    f, g = model.f(X, yaw), model.g(X, yaw)
    eps = 1e-6

    def d(direction, attr):
        a = getattr(model.point_kinematics(X + eps * direction, yaw), attr)
        b = getattr(model.point_kinematics(X - eps * direction, yaw), attr)
        return (a - b) / (2 * eps)

    np.testing.assert_allclose(d(f, "position"), kin.velocity, atol=1e-7)
    np.testing.assert_allclose(d(f, "velocity"), kin.accel_drift, atol=1e-7)
    for j in range(model.n_u):
        np.testing.assert_allclose(d(g[..., j], "position"), 0.0, atol=1e-7)
        np.testing.assert_allclose(d(g[..., j], "velocity"), kin.accel_input[..., j], atol=1e-7)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: repr(m))
def test_scalar_kinematics_match_batched(model):
    rng = np.random.default_rng(3)
    X = random_states(model, rng, 50)
    for x in X:
        yaw = float(rng.uniform(-3, 3)) if model.needs_yaw else None
        a = model.point_kinematics(x, yaw)
        b = model.point_kinematics_tuple(x.tolist(), yaw)
        for ka, kb in zip(a, b, strict=True):
            np.testing.assert_allclose(ka, np.array(kb, dtype=float), rtol=0, atol=1e-15)


def _terms(model, x, c, cv, r, plane, yaw=None, v_eps=DEFAULT_V_EPS):
    return c3bf_lie_derivatives(
        model, x, np.atleast_2d(c), np.atleast_2d(cv), np.atleast_1d(r), np.atleast_1d(plane),
        yaw=yaw, v_eps=v_eps,
    )


def test_combined_models_reduce_to_paper_models_at_zero_yaw_and_offset():
    rng = np.random.default_rng(11)
    uni, xz, hol = UnicycleModel(0.0), XZDoubleIntegratorModel(), HolonomicModel()
    uh, hh = UnicycleHeightModel(0.0), HolonomicHeightModel()
    for _ in range(200):
        x, y, v, w, z, vz, vy = rng.uniform(-2, 2, 7)
        c = rng.uniform(-5, 5, 2) + 3.0
        cv = rng.uniform(-2, 2, 2)
        r = 0.5
        s_uh = np.array([x, y, 0.0, v, w, z, vz])
        # Horizontal obstacle: unicycle+height == x-z double integrator with vx = v.
        a = _terms(uh, s_uh, c, cv, r, Plane.HORIZONTAL)
        b = _terms(xz, np.array([x, z, v, vz]), c, cv, r, Plane.HORIZONTAL)
        np.testing.assert_allclose(a.h, b.h, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(a.lf_h, b.lf_h, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(a.lg_h[:, [0, 2]], b.lg_h, rtol=1e-13, atol=1e-13)
        assert a.lg_h[0, 1] == 0.0
        # Vertical obstacle: unicycle+height == unicycle.
        a = _terms(uh, s_uh, c, cv, r, Plane.VERTICAL)
        b = _terms(uni, np.array([x, y, 0.0, v, w]), c, cv, r, Plane.VERTICAL)
        np.testing.assert_allclose(a.h, b.h, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(a.lf_h, b.lf_h, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(a.lg_h[:, :2], b.lg_h, rtol=1e-13, atol=1e-13)
        assert a.lg_h[0, 2] == 0.0
        # Holonomic+height at yaw 0: x-z DI (inputs a_x, a_z) and holonomic x-y.
        s_hh = np.array([x, y, v, vy, z, vz])
        a = _terms(hh, s_hh, c, cv, r, Plane.HORIZONTAL, yaw=0.0)
        b = _terms(xz, np.array([x, z, v, vz]), c, cv, r, Plane.HORIZONTAL)
        np.testing.assert_allclose(a.lf_h, b.lf_h, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(a.lg_h[:, [0, 2]], b.lg_h, rtol=1e-13, atol=1e-13)
        assert a.lg_h[0, 1] == 0.0
        a = _terms(hh, s_hh, c, cv, r, Plane.VERTICAL, yaw=0.0)
        b = _terms(hol, np.array([x, y, v, vy]), c, cv, r, Plane.VERTICAL, yaw=0.0)
        np.testing.assert_allclose(a.lf_h, b.lf_h, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(a.lg_h[:, :2], b.lg_h, rtol=1e-13, atol=1e-13)


def test_paper_xz_lg_h_corrected_formula():
    """Lg h = [<p + v s/|v|, (-1, 0)>, <p + v s/|v|, (0, -1)>] with s = sqrt(|p|^2 - r^2).

    (The paper prints sqrt(|v|^2 - r^2) in the second row: a typo.)
    """
    rng = np.random.default_rng(5)
    model = XZDoubleIntegratorModel()
    for _ in range(100):
        x = rng.uniform(-2, 2, 4)
        c = x[:2] + rng.uniform(1.0, 4.0, 2) * rng.choice([-1, 1], 2)
        cv = rng.uniform(-2, 2, 2)
        r = 0.7
        t = _terms(model, x, c, cv, r, Plane.HORIZONTAL, v_eps=0.0)
        p, v = c - x[:2], cv - x[2:]
        s = np.sqrt(p @ p - r * r)
        w = p + v * s / np.linalg.norm(v)
        np.testing.assert_allclose(t.lg_h[0], [-w[0], -w[1]], rtol=1e-13)
        # Lf h = <dh/dp, v_rel> (no drift acceleration): <v + |v| p / s, v>, to rounding of
        # its terms (they cancel where v_rel nearly follows the cone's edge).
        terms = v @ v + np.linalg.norm(v) * abs(p @ v) / s
        np.testing.assert_allclose(t.lf_h[0], (v + np.linalg.norm(v) * p / s) @ v, rtol=1e-13,
                                   atol=1e-15 * terms)


def test_horizontal_bar_couples_yaw_acceleration_when_offset_nonzero():
    """x-velocity of the body point is v cos th - l w sin th: alpha enters via -l sin th."""
    model = UnicycleHeightModel(offset=0.3)
    x = np.array([0.0, 0.0, 0.4, 1.0, 0.2, 0.3, 0.0])
    t = _terms(model, x, [3.0, 0.9], [0.0, 0.0], 0.5, Plane.HORIZONTAL)
    assert np.all(np.abs(t.lg_h[0]) > 1e-3)  # a, alpha AND a_z all act on the bar constraint
    t0 = _terms(UnicycleHeightModel(offset=0.0), x, [3.0, 0.9], [0.0, 0.0], 0.5, Plane.HORIZONTAL)
    assert t0.lg_h[0, 1] == 0.0
