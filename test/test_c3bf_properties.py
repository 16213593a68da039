"""Property tests (hypothesis) of the safety filter."""

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from safe_legged_c3bf.c3bf import (
    FilterStatus,
    HolonomicHeightModel,
    HolonomicModel,
    Obstacles,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleLateralHeightModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
    c3bf_lie_derivatives,
)
from safe_legged_c3bf.c3bf.lie import PLANE_AXES

MODELS = [
    UnicycleModel(offset=0.2),
    UnicycleModel(offset=0.0),
    XZDoubleIntegratorModel(),
    HolonomicModel(),
    UnicycleHeightModel(offset=0.15),
    HolonomicHeightModel(),
    UnicycleLateralHeightModel(offset=0.2),
]
RANGES = {
    "x": (-5, 5), "y": (-5, 5), "theta": (-np.pi, np.pi), "v": (-1.0, 2.5),
    "omega": (-1.5, 1.5), "z": (0.1, 0.5), "vz": (-0.8, 0.8), "vx": (-2.5, 2.5),
    "vy": (-2.5, 2.5), "v_l": (-1.0, 1.0),
}
SETTINGS = settings(max_examples=250, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])

unit = st.floats(0.0, 1.0, allow_nan=False)


@st.composite
def scenarios(draw):
    model = draw(st.sampled_from(MODELS))
    lo_hi = [RANGES[s] for s in model.state_names]
    x = np.array([lo + draw(unit) * (hi - lo) for lo, hi in lo_hi])
    yaw = draw(st.floats(-np.pi, np.pi)) if model.needs_yaw else None
    n = draw(st.integers(1, 6))
    planes = sorted(int(p) for p in model.planes)
    kin = model.point_kinematics(x, yaw)
    cen, vel, rad, pl = [], [], [], []
    for _ in range(n):
        k = draw(st.sampled_from(planes))
        r = draw(st.floats(0.15, 1.0))
        # Distance from r (1 + 1e-3) (near-tangent) to 10 m; some obstacles fast (5 m/s).
        near = draw(st.integers(0, 4)) == 0
        d = r * (1.0 + 10 ** (draw(st.floats(-3.0, 0.0)) if near else draw(st.floats(0.0, 1.3))))
        ang = draw(st.floats(-np.pi, np.pi))
        P = kin.position[PLANE_AXES[k]]
        cen.append(P + d * np.array([np.cos(ang), np.sin(ang)]))
        speed = draw(st.sampled_from([0.0, 0.0, 0.5, 1.0, 2.0, 5.0]))
        vel.append(speed * np.array([draw(unit) * 2 - 1, draw(unit) * 2 - 1]))
        rad.append(r)
        pl.append(k)
    obs = Obstacles(np.array(cen), np.array(vel), np.array(rad), np.array(pl))
    m = model.n_u
    u_min = np.array([-(0.3 + 2.7 * draw(unit)) for _ in range(m)])
    u_max = np.array([0.3 + 2.7 * draw(unit) for _ in range(m)])
    u_ref = np.array([3.5 * (2 * draw(unit) - 1) for _ in range(m)])
    w = np.array([0.2 + 4.8 * draw(unit) for _ in range(m)])
    gamma = draw(st.sampled_from([0.5, 1.0, 3.0]))
    return model, x, yaw, obs, u_ref, u_min, u_max, w, gamma


def make_filter(model, u_min, u_max, w, gamma):
    # margin = 0: the constraints are exactly the paper's, checked independently below.
    return SafetyFilter(model, gamma=gamma, weights=w, u_min=u_min, u_max=u_max, margin=0.0)


def independent_constraints(flt, x, yaw, obs):
    t = c3bf_lie_derivatives(flt.model, x, obs.center, obs.velocity, obs.radius, obs.plane,
                             yaw=yaw, v_eps=flt.v_eps)
    return t.lg_h, t.lf_h + flt.gamma * t.h


def feasibility_margin(G, c0, u_min, u_max):
    """max t s.t. (G u + c0) / ||G|| >= t, u_min <= u <= u_max (LP, HiGHS)."""
    nrm = np.maximum(np.linalg.norm(G, axis=1), 1e-12)
    Gn, bn = G / nrm[:, None], -c0 / nrm
    m = G.shape[1]
    res = linprog(
        c=np.r_[np.zeros(m), -1.0],
        A_ub=np.c_[-Gn, np.ones(len(bn))],
        b_ub=-bn,
        bounds=[(lo, hi) for lo, hi in zip(u_min, u_max, strict=True)] + [(None, 1.0)],
        method="highs",
    )
    return -res.fun if res.status == 0 else -np.inf


@SETTINGS
@given(scenarios())
def test_output_finite_within_limits_and_feasible_constraints_hold(sc):
    model, x, yaw, obs, u_ref, u_min, u_max, w, gamma = sc
    flt = make_filter(model, u_min, u_max, w, gamma)
    r = flt.filter(x, u_ref, obs, yaw=yaw)
    assert np.isfinite(r.u_safe).all()
    assert np.all((r.u_safe >= u_min) & (r.u_safe <= u_max))
    for arr in (r.h, r.constraint, r.slack):
        assert np.isfinite(arr).all() and arr.shape == (len(obs),)
    assert r.status is not FilterStatus.FAILSAFE
    G, c0 = independent_constraints(flt, x, yaw, obs)
    con = G @ r.u_safe + c0
    np.testing.assert_allclose(r.constraint, con, rtol=1e-9, atol=1e-9)
    t = feasibility_margin(G, c0, u_min, u_max)
    event(f"{r.status.value}/{r.solver}")
    if t > 1e-6:  # the QP is (strictly) feasible: every constraint must hold
        assert r.status in (FilterStatus.ACTIVE, FilterStatus.INACTIVE)
        assert np.all(con >= -1e-6), (con, r.status, r.solver)
    elif t < -1e-6:
        assert r.status is FilterStatus.RELAXED


@SETTINGS
@given(scenarios())
def test_minimal_intervention_and_idempotence(sc):
    model, x, yaw, obs, u_ref, u_min, u_max, w, gamma = sc
    flt = make_filter(model, u_min, u_max, w, gamma)
    G, c0 = independent_constraints(flt, x, yaw, obs)
    u_in = np.clip(u_ref, u_min, u_max)
    r = flt.filter(x, u_in, obs, yaw=yaw)
    event(f"{r.status.value}/{r.solver}")
    if np.all(G @ u_in + c0 >= 0.0):
        assert r.status is FilterStatus.INACTIVE
        np.testing.assert_array_equal(r.u_safe, u_in)
    if r.status is FilterStatus.ACTIVE:
        # Filtering the filtered input again changes (almost) nothing.
        r2 = flt.filter(x, r.u_safe, obs, yaw=yaw)
        np.testing.assert_allclose(r2.u_safe, r.u_safe, atol=1e-7)


@SETTINGS
@given(scenarios())
def test_closed_form_and_osqp_paths_agree(sc):
    model, x, yaw, obs, u_ref, u_min, u_max, w, gamma = sc
    a = make_filter(model, u_min, u_max, w, gamma)
    q = SafetyFilter(model, gamma=gamma, weights=w, u_min=u_min, u_max=u_max, margin=0.0,
                     method="qp")
    ra, rq = a.filter(x, u_ref, obs, yaw=yaw), q.filter(x, u_ref, obs, yaw=yaw)
    assert ra.status == rq.status
    if ra.status in (FilterStatus.ACTIVE, FilterStatus.INACTIVE):
        np.testing.assert_allclose(ra.u_safe, rq.u_safe, atol=1e-5)
