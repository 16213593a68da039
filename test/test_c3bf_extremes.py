"""Property tests: every public function of ``safe_legged_c3bf.c3bf`` at magnitudes up to
1e300 gives the right answer (checked against exact rational, 80-digit decimal or
complex-step oracles, see ``test_c3bf_oracle``) or raises a clear InvalidInputError naming
the argument; never a silent wrong answer."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.optimize import nnls
from test_c3bf_oracle import (
    as_float,
    complex_h,
    complex_step,
    exact_h,
    exact_qp,
    exact_speed,
)

from safe_legged_c3bf.c3bf import (
    FilterStatus,
    HolonomicHeightModel,
    HolonomicModel,
    InvalidInputError,
    Obstacles,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleLateralHeightModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
    c3bf_gradient,
    c3bf_lie_derivatives,
    c3bf_value,
    cbf_closed_form,
    inflated_radius,
    regularized_speed,
)
from safe_legged_c3bf.c3bf.domain import MAX_DERIVED, MAX_MAGNITUDE, REF_RATIO_MAX
from safe_legged_c3bf.c3bf.lie import PLANE_AXES

MODELS = [UnicycleModel(0.2), XZDoubleIntegratorModel(), HolonomicModel(),
          UnicycleHeightModel(0.15), HolonomicHeightModel(), UnicycleLateralHeightModel(0.15)]
RANGES = {"theta": (-np.pi, np.pi), "v": (-1.0, 2.0), "omega": (-1.5, 1.5), "z": (0.1, 0.5),
          "vz": (-0.8, 0.8), "vx": (-2.0, 2.0), "vy": (-2.0, 2.0), "v_l": (-0.5, 0.5)}
SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])
unit = st.floats(0.0, 1.0)


def magnitude(lo, hi):
    """Signed log-uniform magnitudes 10^[lo, hi]."""
    return st.builds(lambda e, s: s * 10.0**e, st.floats(lo, hi), st.sampled_from([-1, 1]))


@st.composite
def states(draw, model, extreme=False):
    x = np.array([lo + draw(unit) * (hi - lo)
                  for lo, hi in (RANGES.get(s, (-5, 5)) for s in model.state_names)])
    if extreme:  # some entries (any kind) pushed to 10^[0, 9.2] or to 10^[0, 300]
        top = draw(st.sampled_from([9.2, 300.0]))
        for i in range(model.n_x):
            if draw(st.integers(0, 2)) == 0:
                x[i] = draw(magnitude(0, top))
    return x


@st.composite
def obstacles_near(draw, model, x, yaw):
    """0..3 obstacles outside their circle, from near-tangent to 10 m, some moving."""
    kin = model.point_kinematics(x, yaw)
    planes = sorted(int(p) for p in model.planes)
    cen, vel, rad, pl = [], [], [], []
    for _ in range(draw(st.integers(0, 3))):
        k = draw(st.sampled_from(planes))
        r = draw(st.floats(0.15, 1.0))
        d = r * (1.0 + 10.0 ** draw(st.floats(-2.0, 1.0)))
        ang = draw(st.floats(-np.pi, np.pi))
        cen.append(kin.position[PLANE_AXES[k]] + d * np.array([np.cos(ang), np.sin(ang)]))
        vel.append(draw(st.sampled_from([0.0, 0.5, 2.0])) * np.array([draw(unit) - 0.5,
                                                                       draw(unit) - 0.5]))
        rad.append(r)
        pl.append(k)
    if not cen:
        return Obstacles.empty()
    return Obstacles(np.array(cen), np.array(vel), np.array(rad), np.array(pl))


@st.composite
def limits(draw, m):
    lo = np.array([-draw(magnitude(-1, 9.5)) if draw(st.integers(0, 5)) else -np.inf
                   for _ in range(m)])
    hi = np.array([draw(magnitude(-1, 9.5)) if draw(st.integers(0, 5)) else np.inf
                   for _ in range(m)])
    return -np.abs(lo), np.abs(hi)


@st.composite
def weights(draw, m):
    w = np.array([0.2 + 4.8 * draw(unit) for _ in range(m)])
    if draw(st.booleans()):
        return np.diag(w)
    L = np.array([[draw(st.floats(-1, 1)) for _ in range(m)] for _ in range(m)])
    return L @ L.T + np.diag(w)


def problem_rows(flt, x, yaw, obs):
    """Independent rows ``G u >= b`` of the filter's QP (vectorised Lie derivatives)."""
    m = flt.model.n_u
    if len(obs) == 0:
        return np.zeros((0, m)), np.zeros(0), np.zeros(0)
    t = c3bf_lie_derivatives(flt.model, x, obs.center, obs.velocity, obs.radius, obs.plane,
                             yaw=yaw, v_eps=flt.v_eps)
    size = np.abs(t.lf_h) + flt.gamma * np.abs(t.h)  # magnitude of the rounded terms
    return t.lg_h, -(t.lf_h + flt.gamma * t.h), size


def kkt_holds(u, W, u0, G, b, lo, hi, delta):
    """Backward check: ``u`` is the optimum for rows moved by at most ``delta`` (unit rows):
    feasible within ``delta`` and ``W (u - u0) = A_S^T lam``, ``lam >= 0`` (NNLS) over the
    rows within ``delta`` of binding (limits included)."""
    m = len(u)
    nrm = np.linalg.norm(G, axis=1)
    A = np.vstack([G / nrm[:, None], np.eye(m), -np.eye(m)])
    rhs = np.r_[b / nrm, lo, -hi]
    keep = np.isfinite(rhs)
    slack = A[keep] @ u - rhs[keep]
    if slack.min(initial=0.0) < -delta:
        return False
    g = W @ (u - u0)
    S = A[keep][slack <= delta]
    if len(S) == 0:
        return np.abs(g).max() <= delta
    _, res = nnls(S.T, g)
    return res <= 1e-9 * (1.0 + np.abs(g).max())


def check_against_exact(r, flt, u_ref, G, b, size):
    """``r`` is the exact optimum of ``G u >= b`` and the limits, up to the rounding of
    the data. The rows are known to ``delta`` (their terms' rounding) and entries below
    1e-12 of a row (e.g. ``-l sin(pi)``) are rounding noise: ACTIVE/INACTIVE within 1e-6 of
    the exact optimum when the problem stays feasible with every row tightened by ``delta``
    and the optimum does not depend on the noise; RELAXED when it stays infeasible with the
    rows loosened by ``delta``; anything but FAILSAFE in between (ill-posed)."""
    lo, hi, W = flt.u_min, flt.u_max, flt.weights
    assert np.isfinite(r.u_safe).all() and np.all((r.u_safe >= lo) & (r.u_safe <= hi))
    scale = 1.0 + np.abs(np.r_[lo, hi][np.isfinite(np.r_[lo, hi])]).max(initial=0.0)
    delta = 1e-7 * np.linalg.norm(G, axis=1) * scale + 1e-11 * size
    noise = np.abs(G) < 1e-12 * np.abs(G).max(axis=1, initial=0.0)[:, None]
    variants = [G, np.where(noise, 0.0, G)] if noise.any() else [G]
    if all(exact_qp(W, u_ref, g, b + delta, lo, hi) is not None for g in variants):
        u_ex = [as_float(exact_qp(W, u_ref, g, b, lo, hi)) for g in variants]
        tol = 1e-6 * (1 + max(np.abs(u).max() for u in u_ex))
        # An optimum far beyond the problem's own scale exists only through rounding-level
        # non-parallelism of rows (e.g. every bar row sees (a, alpha) as c a - l s alpha).
        own = 1.0 + np.abs(u_ref).max() + (np.abs(b) / np.linalg.norm(G, axis=1)).max(
            initial=0.0)
        if np.abs(u_ex[0] - u_ex[-1]).max() <= tol and np.abs(u_ex[0]).max() <= 1e6 * own:
            assert r.status in (FilterStatus.ACTIVE, FilterStatus.INACTIVE), r
            # Exact for rows moved by the active-set method's tolerance, 1e-12 (1 + |u_ref|)
            # (it works in u - u_ref); OSQP's tolerance (1e-7) is relative to |W u_ref|.
            tol += 1e-11 * np.abs(u_ref).max()
            if r.solver == "osqp":
                tol += 1e-6 * np.abs(W @ u_ref).max() / np.linalg.eigvalsh(W).min()
            if np.abs(r.u_safe - u_ex[0]).max() > tol:  # ill-conditioned: backward check
                backward = 1e-11 * (1.0 + np.abs(u_ref).max()) + 1e-7 * scale
                assert kkt_holds(r.u_safe, W, u_ref, G, b, lo, hi, backward), (r, u_ex[0])
                event("checked backward")
            return
    elif all(exact_qp(W, u_ref, g, b - delta, lo, hi) is None for g in variants):
        assert r.status is FilterStatus.RELAXED, r
        return
    event("ill-posed")
    assert r.status is not FilterStatus.FAILSAFE, r


@st.composite
def reference_problems(draw):
    model = draw(st.sampled_from(MODELS))
    x = draw(states(model))
    yaw = draw(st.floats(-np.pi, np.pi)) if model.needs_yaw else None
    obs = draw(obstacles_near(model, x, yaw))
    m = model.n_u
    lo, hi = draw(limits(m))
    d = np.array([draw(st.floats(-1, 1)) for _ in range(m)])
    # Magnitudes 1e-2..1e300, half of them around the bound (REF_RATIO_MAX x the scale).
    top = draw(st.sampled_from([300.0, 12.0]))
    u_ref = d / max(np.abs(d).max(), 1e-3) * 10.0 ** draw(st.floats(-2, top))
    return model, x, yaw, obs, lo, hi, draw(weights(m)), u_ref, draw(st.sampled_from(
        ["auto", "qp"]))


@SETTINGS
@given(reference_problems())
def test_filter_with_references_up_to_1e300_is_exact_or_refused(p):
    model, x, yaw, obs, lo, hi, W, u_ref, method = p
    finite = np.r_[lo, hi][np.isfinite(np.r_[lo, hi])]
    if np.abs(finite).max(initial=0.0) > MAX_MAGNITUDE:
        with pytest.raises(InvalidInputError, match="finite input limits must be within"):
            SafetyFilter(model, u_min=lo, u_max=hi)
        event("limits refused")
        return
    flt = SafetyFilter(model, weights=W, u_min=lo, u_max=hi, margin=0.0, method=method)
    G, b, size = problem_rows(flt, x, yaw, obs)
    scale = 1.0 + np.abs(np.r_[lo, hi][np.isfinite(np.r_[lo, hi])]).max(initial=0.0)
    far = np.abs(u_ref).max() > REF_RATIO_MAX * scale
    try:
        r = flt.filter(x, u_ref, obs, yaw=yaw)
    except InvalidInputError as err:
        event("refused")
        assert far and "u_ref" in str(err), err
        return
    event(f"{'far ' if far else ''}{r.status.value}/{r.solver}")
    check_against_exact(r, flt, u_ref, G, b, size)


@SETTINGS
@given(st.data())
def test_filter_with_states_up_to_1e300_is_right_or_refused(data):
    model = data.draw(st.sampled_from(MODELS))
    x = data.draw(states(model, extreme=True))
    yaw = data.draw(st.floats(-np.pi, np.pi)) if model.needs_yaw else None
    m = model.n_u
    lo, hi = -np.full(m, 2.0), np.full(m, 2.0)
    flt = SafetyFilter(model, u_min=lo, u_max=hi, margin=0.0)
    if np.abs(x).max() > MAX_MAGNITUDE:
        with pytest.raises(InvalidInputError, match=r"state\[\d\] = .* is beyond"):
            flt.filter(x, np.zeros(m), Obstacles.empty(), yaw=yaw)
        event("refused")
        return
    try:
        obs = data.draw(obstacles_near(model, x, yaw))
    except InvalidInputError as err:  # an obstacle placed beyond the domain
        assert "is beyond" in str(err)
        event("obstacle beyond the domain")
        return
    u_ref = np.array([data.draw(st.floats(-3, 3)) for _ in range(m)])
    r = flt.filter(x, u_ref, obs, yaw=yaw)
    event(f"{r.status.value}/{r.solver}")
    G, b, size = problem_rows(flt, x, yaw, obs)
    check_against_exact(r, flt, u_ref, G, b, size)


@SETTINGS
@given(st.integers(1, 3).flatmap(lambda m: st.tuples(
    st.lists(magnitude(-300, 300), min_size=m, max_size=m),
    st.lists(magnitude(-300, 300), min_size=m, max_size=m),
    magnitude(-300, 300), magnitude(-300, 300), st.floats(0, 5), weights(m))))
def test_closed_form_is_exact_or_refused(args):
    a, u0, lf, h, gamma, W = (np.array(args[0]), np.array(args[1]), *args[2:])
    w_inv = np.linalg.inv(W)
    values = np.abs(np.r_[a, u0, lf, h, w_inv.ravel()])
    try:
        u = cbf_closed_form(a, lf, h, u0, gamma, w_inv)
    except InvalidInputError as err:
        event("refused")
        assert values.max() > MAX_DERIVED or "overflows" in str(err), err
        return
    assert values.max() <= MAX_DERIVED
    F = [Fraction(float(v)) for v in a]
    U = [Fraction(float(v)) for v in u0]
    psi = Fraction(lf) + sum(x * y for x, y in zip(F, U, strict=True)) + Fraction(gamma) * \
        Fraction(h)
    Wi = [[Fraction(float(v)) for v in row] for row in w_inv]
    wa = [sum(Wi[i][j] * F[j] for j in range(len(F))) for i in range(len(F))]
    den = sum(x * y for x, y in zip(F, wa, strict=True))
    exact = U if psi >= 0 or den == 0 else [x - w * psi / den for x, w in zip(U, wa,
                                                                               strict=True)]
    # Backward stable: exact for data moved by a few ulps (psi rounds to ~4 eps its terms).
    err_psi = 4e-16 * (abs(lf) + np.abs(a * u0).sum() + gamma * abs(h))
    kappa = np.linalg.cond(W)
    tol = 1e-15 * (np.abs(u0).max() + np.abs(as_float(exact)).max()) + \
        10 * kappa * err_psi / max(np.linalg.norm(a), 1e-300)
    event("moved" if psi < 0 else "unchanged")
    assert np.abs(u - as_float(exact)).max() <= tol


@pytest.mark.filterwarnings("error")  # no overflow in unused branches either
@SETTINGS
@given(st.lists(magnitude(-300, 300), min_size=2, max_size=2),
       st.lists(magnitude(-300, 300), min_size=2, max_size=2),
       st.floats(0.0, 0.99), st.sampled_from([0.0, 0.05, 0.5]))
def test_barrier_value_gradient_and_speed_are_right_or_refused(p, v, frac, v_eps):
    regularized_speed(np.array([1e50, 0.0]), 0.05)  # (no overflow in the unused blend)
    p, v = np.array(p), np.array(v)
    pn, vn = math.hypot(*p), math.hypot(*v)  # (no underflow, unlike np.linalg.norm)
    r = max(frac * pn, 1e-300) if np.isfinite(pn) else 1.0
    if max(np.abs(p).max(), np.abs(v).max(), r) > MAX_DERIVED:
        for fn in (c3bf_value, c3bf_gradient):
            with pytest.raises(InvalidInputError, match="is beyond"):
                fn(p, v, r, v_eps)
        event("refused")
        return
    h = c3bf_value(p, v, r, v_eps)
    n = regularized_speed(v, v_eps)
    s = pn * math.sqrt(max(1.0 - (r / pn) ** 2, 0.0)) if pn > 0 else 0.0
    # Relative accuracy of the terms, and the floor below which squares are subnormal
    # (||v||^2 < 2e-308 keeps only a few bits: absolute error ~5e-324 in it).
    floor = 2 * (s * min(vn, 1e-322 / max(vn, 1e-300)) + n * min(s, 1e-322 / max(s, 1e-300)))
    # s = sqrt(|p|^2 - r^2) near the tangent: absolute error ~ eps |p|^2 / s.
    s_err = min(pn, 1e-15 * pn * (pn / max(s, 1e-300))) + 1e-322 / max(s, 1e-300)
    floor += 1e-321  # a few subnormal ulps
    assert abs(h - exact_h(p, v, r, v_eps)) <= 1e-14 * (pn * vn + n * s) + n * s_err + floor
    assert abs(n - exact_speed(v, v_eps)) <= 1e-14 * n + 1e-322 / max(vn, 1e-300)
    hg, dp, dv, s_out = c3bf_gradient(p, v, r, v_eps)
    assert hg == h and abs(s_out - s) <= s_err
    # Analytic (away from the clamps; the p / s term uses s_min = 1e-12 m below it).
    analytic = s > max(1e-3 * pn, 1e-9) and (v_eps == 0 or abs(vn - v_eps) > 1e-3 * v_eps)
    if analytic and min(pn, vn) > 1e-100:  # (complex steps of tinier values underflow)
        for k in range(2):
            e = np.eye(2)[k]
            g_p = complex_step(lambda z: complex_h(z, v + 0j, r, v_eps), p, e, 1e-30 * pn)
            g_v = complex_step(lambda z: complex_h(p + 0j, z, r, v_eps), v, e,
                               1e-30 * max(vn, v_eps))
            assert abs(dp[k] - g_p) <= 1e-12 * (vn + n * pn / s)
            assert abs(dv[k] - g_v) <= 1e-12 * (pn + s)
    event("checked")


@SETTINGS
@given(st.data())
def test_models_and_lie_derivatives_are_right_or_refused(data):
    model = data.draw(st.sampled_from(MODELS))
    x = data.draw(states(model, extreme=True))
    yaw = data.draw(st.floats(-np.pi, np.pi)) if model.needs_yaw else None
    if np.abs(x).max() > MAX_MAGNITUDE:
        for fn in (model.f, model.g, model.point_kinematics, model.brake_input):
            with pytest.raises(InvalidInputError, match=r"state\[\d\] = .* is beyond"):
                fn(x, yaw)
        event("refused")
        return
    kin = model.point_kinematics(x, yaw)
    f, g = model.f(x, yaw), model.g(x, yaw)
    # Body-point kinematics against complex-step derivatives of the model's own P(x), V(x).
    def point(z, part):
        return np.array(model._kin(list(z), yaw, np.cos, np.sin)[part], dtype=complex)
    mag = 1.0 + np.abs(x).max()
    for part, d, want in [(0, f, kin.velocity), (1, f, kin.accel_drift)] + \
            [(0, g[:, j], np.zeros(3)) for j in range(model.n_u)] + \
            [(1, g[:, j], kin.accel_input[:, j]) for j in range(model.n_u)]:
        got = complex_step(lambda z, part=part: point(z, part), x + 0j, d, 1e-30)
        np.testing.assert_allclose(want, got, rtol=1e-12, atol=1e-14 * mag**3)
    # brake_input drives every velocity state to zero at rate gain.
    gain = data.draw(st.floats(0.0, 5.0))
    vel = [i for i, s in enumerate(model.state_names) if s in ("v", "omega", "vx", "vy", "vz")]
    np.testing.assert_allclose((g @ model.brake_input(x, yaw, gain))[vel], -gain * x[vel],
                               rtol=1e-12, atol=1e-15 * mag)
    # Lie derivatives: complex-step derivatives of h along f (and the obstacle) and g_j.
    try:
        obs = data.draw(obstacles_near(model, x, yaw))
    except InvalidInputError:
        event("obstacle beyond the domain")
        return
    if len(obs) == 0:
        return
    t = c3bf_lie_derivatives(model, x, obs.center, obs.velocity, obs.radius, obs.plane,
                             yaw=yaw)
    # Against complex steps of the barrier along d p_rel/dt = v_rel, d v_rel/dt = -(A + B u)
    # (V, A, B themselves are checked against the model's P(x) above).
    axes = PLANE_AXES[obs.plane]
    p = obs.center - kin.position[axes]
    v = obs.velocity - kin.velocity[axes]
    A, Bm = kin.accel_drift[axes], kin.accel_input[axes]
    _, dh_dp, dh_dv, _ = c3bf_gradient(t.p_rel, t.v_rel, obs.radius)
    scale = np.abs(dh_dp * t.v_rel).sum(-1) + np.abs(dh_dv * A).sum(-1) + np.abs(t.lf_h)
    step = 1e-30  # Im parts = value * step: values below ~1e-277 underflow (floor below)

    def along(dp, dv):
        return complex_h(p + 1j * step * dp, v + 1j * step * dv, obs.radius, 0.05).imag / step

    lf_cs = along(v, -A)
    assert np.all(np.abs(t.lf_h - lf_cs) <= 1e-10 * scale + 1e-277), (t.lf_h, lf_cs)
    for j in range(model.n_u):
        lg_cs = along(np.zeros_like(v), -Bm[..., j])
        bound = 1e-10 * np.abs(dh_dv * Bm[..., j]).sum(-1) + 1e-277
        assert np.all(np.abs(t.lg_h[:, j] - lg_cs) <= bound), (t.lg_h[:, j], lg_cs)
    event(f"checked {len(obs)}")


@SETTINGS
@given(magnitude(-300, 300), magnitude(-300, 300), magnitude(-300, 300))
def test_inflated_radius_and_obstacles_are_right_or_refused(c1, c2, dim):
    c1, c2, dim = abs(c1), abs(c2), abs(dim)
    if max(c1, c2, dim) > MAX_MAGNITUDE:
        with pytest.raises(InvalidInputError, match="is beyond"):
            inflated_radius(c1, c2, dim)
        with pytest.raises(InvalidInputError, match="obstacle 0: radius = .* is beyond"):
            Obstacles.vertical([[0.0, 0.0]], [max(c1, c2) + dim])
        return
    r = inflated_radius(c1, c2, dim)
    exact = max(Fraction(c1), Fraction(c2)) + Fraction(dim) / 2
    assert abs(Fraction(r) - exact) <= exact * Fraction(1, 2**52)
    if r > MAX_MAGNITUDE:  # (1e9 + 0.5: the inflated radius itself is beyond the domain)
        with pytest.raises(InvalidInputError, match="obstacle 0: radius = .* is beyond"):
            Obstacles.vertical([[0.0, 0.0]], [r])
    else:
        assert Obstacles.vertical([[0.0, 0.0]], [r]).radius[0] == r
