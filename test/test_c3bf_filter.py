"""Safety filter: optimality (closed form, OSQP, brute force), statuses and edge cases."""

import itertools

import numpy as np
import pytest

from safe_legged_c3bf.c3bf import (
    DEFAULT_V_EPS,
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
    c3bf_lie_derivatives,
    cbf_closed_form,
)
from safe_legged_c3bf.c3bf import filter as filter_mod
from safe_legged_c3bf.c3bf import osqp_qp as qp_mod
from safe_legged_c3bf.c3bf.lie import PLANE_AXES


def brute_force_qp(G, b, u0, W, lo, hi):
    """Exact min (u-u0)'W(u-u0) s.t. G u >= b, lo <= u <= hi by active-set enumeration."""
    m = len(u0)
    A = np.vstack([G, np.eye(m), -np.eye(m)])
    rhs = np.concatenate([b, lo, -hi])
    keep = np.isfinite(rhs)
    A, rhs = A[keep], rhs[keep]
    best, best_cost = None, np.inf
    for k in range(m + 1):
        for S in itertools.combinations(range(len(A)), k):
            S = list(S)
            K = np.block([[W, -A[S].T], [A[S], np.zeros((k, k))]])
            try:
                sol = np.linalg.solve(K, np.concatenate([W @ u0, rhs[S]]))
            except np.linalg.LinAlgError:
                continue
            u = sol[:m]
            scale = np.maximum(np.linalg.norm(A, axis=1), 1.0)
            if np.all(A @ u - rhs >= -1e-9 * scale):
                cost = (u - u0) @ W @ (u - u0)
                if cost < best_cost - 1e-12:
                    best, best_cost = u, cost
    return best, best_cost


def terms_for(flt, x, obs, yaw=None):
    return c3bf_lie_derivatives(
        flt.model, x, obs.center, obs.velocity, obs.radius + flt.margin, obs.plane, yaw=yaw,
        v_eps=flt.v_eps,
    )


def random_problem(rng, model, n, spread=4.0):
    x = np.zeros(model.n_x)
    names = model.state_names
    for i, s in enumerate(names):
        x[i] = {"theta": rng.uniform(-0.5, 0.5), "v": rng.uniform(0.5, 1.5),
                "vx": rng.uniform(0.5, 1.5), "z": 0.3}.get(s, rng.uniform(-0.2, 0.2))
    planes = sorted(int(p) for p in model.planes)
    plane = np.array([planes[i % len(planes)] for i in range(n)])
    c = np.c_[rng.uniform(1.5, spread, n), rng.uniform(-1.0, 1.0, n)]
    c[plane == 1, 1] = 0.3 + rng.uniform(-0.3, 0.3, (plane == 1).sum())
    obs = Obstacles(c, rng.uniform(-1, 1, (n, 2)), rng.uniform(0.2, 0.6, n), plane)
    u_ref = rng.uniform(-1, 1, model.n_u)
    return x, u_ref, obs


MODELS = [
    UnicycleModel(offset=0.2),
    XZDoubleIntegratorModel(),
    HolonomicModel(),
    UnicycleHeightModel(offset=0.15),
    HolonomicHeightModel(),
    UnicycleLateralHeightModel(offset=0.2),
]


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("full_w", [False, True])
def test_filter_is_the_exact_qp_optimum(model, full_w):
    rng = np.random.default_rng(42)
    m = model.n_u
    if full_w:
        L = rng.normal(size=(m, m))
        W = L @ L.T + m * np.eye(m)
    else:
        W = np.diag(rng.uniform(0.5, 3.0, m))
    lo, hi = -np.full(m, 2.0), np.full(m, 2.5)
    auto = SafetyFilter(model, weights=W, u_min=lo, u_max=hi)
    qp = SafetyFilter(model, weights=W, u_min=lo, u_max=hi, method="qp")
    yaw = 0.3 if model.needs_yaw else None
    seen, seen_qp = set(), set()
    for trial in range(120):
        n = 1 + trial % 5
        x, u_ref, obs = random_problem(rng, model, n)
        ra = auto.filter(x, u_ref, obs, yaw=yaw)
        rq = qp.filter(x, u_ref, obs, yaw=yaw)
        seen.add((ra.status, ra.solver))
        seen_qp.add((rq.status, rq.solver))
        t = terms_for(auto, x, obs, yaw)
        G, b = t.lg_h, -(t.lf_h + auto.gamma * t.h)
        u_bf, cost = brute_force_qp(G, b, u_ref, W, lo, hi)
        if u_bf is None:
            assert ra.status is FilterStatus.RELAXED and rq.status is FilterStatus.RELAXED
            continue
        for r in (ra, rq):
            assert r.status in (FilterStatus.ACTIVE, FilterStatus.INACTIVE)
            assert np.all(r.constraint >= -1e-6)
            np.testing.assert_allclose(r.constraint, G @ r.u_safe - b, atol=1e-9)
            assert np.all((r.u_safe >= lo) & (r.u_safe <= hi))
            got = (r.u_safe - u_ref) @ W @ (r.u_safe - u_ref)
            assert got <= cost + 1e-7 * (1 + cost)
            np.testing.assert_allclose(r.u_safe, u_bf, atol=1e-5)
    # Every path was exercised: closed form (one obstacle), active set (auto), OSQP (qp).
    assert (FilterStatus.ACTIVE, "closed_form") in seen
    assert (FilterStatus.ACTIVE, "active_set") in seen
    assert (FilterStatus.ACTIVE, "osqp") in seen_qp


def test_closed_form_function_matches_paper_formula():
    rng = np.random.default_rng(0)
    for _ in range(200):
        a = rng.normal(size=3)
        u0 = rng.normal(size=3)
        lf, h = rng.normal(), rng.normal()
        u = cbf_closed_form(a, lf, h, u0, gamma=1.0)
        psi = lf + a @ u0 + h
        expected = u0 if psi >= 0 else u0 - a * psi / (a @ a)
        np.testing.assert_allclose(u, expected, rtol=1e-12, atol=1e-12)
        assert lf + a @ u + h >= -1e-12


def test_single_obstacle_uses_closed_form_and_bounds_fall_back_to_active_set():
    model = UnicycleModel(offset=0.2)
    obs = Obstacles.vertical([[3.0, 0.1]], [0.6])
    x = np.array([0.0, 0.0, 0.0, 1.0, 0.0])
    wide = SafetyFilter(model, u_min=[-5, -5], u_max=[5, 5])
    r = wide.filter(x, [0.5, 0.0], obs)
    assert r.status is FilterStatus.ACTIVE and r.solver == "closed_form"
    assert r.active.tolist() == [True] and abs(r.constraint[0]) < 1e-9
    # The closed form needs |alpha| > 0.1 here: with a tight alpha limit the active-set
    # method takes over (and agrees with OSQP).
    tight = SafetyFilter(model, u_min=[-5, -0.05], u_max=[5, 0.05])
    r2 = tight.filter(x, [0.5, 0.0], obs)
    assert r2.solver == "active_set" and r2.status is FilterStatus.ACTIVE
    assert r2.bounds_active.any() and r2.constraint[0] >= -1e-9
    tight_qp = SafetyFilter(model, u_min=[-5, -0.05], u_max=[5, 0.05], method="qp")
    r3 = tight_qp.filter(x, [0.5, 0.0], obs)
    assert r3.solver == "osqp" and r3.status is FilterStatus.ACTIVE
    np.testing.assert_allclose(r2.u_safe, r3.u_safe, atol=1e-6)


def test_reference_passes_unchanged_when_safe():
    model = UnicycleHeightModel(offset=0.2)
    flt = SafetyFilter(model, u_min=[-2, -4, -3], u_max=[2, 4, 3])
    x = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.3, 0.0])
    obs = Obstacles.vertical([[3.0, 3.0], [-2.0, 1.0]], [0.5, 0.5])
    u_ref = np.array([0.3, -0.2, 0.1])
    r = flt.filter(x, u_ref, obs)
    assert r.status is FilterStatus.INACTIVE and r.solver == "none" and not r.modified
    np.testing.assert_array_equal(r.u_safe, u_ref)
    assert r.u_safe is not u_ref
    assert not r.active.any() and np.all(r.slack == 0)
    r0 = flt.filter(x, u_ref, Obstacles.empty())
    assert r0.status is FilterStatus.INACTIVE and r0.h.shape == (0,)
    # Outside the box with no obstacle: W-projection onto the box (clip for diagonal W).
    r1 = flt.filter(x, [5.0, 0.0, -9.0], Obstacles.empty())
    assert r1.status is FilterStatus.ACTIVE
    np.testing.assert_allclose(r1.u_safe, [2.0, 0.0, -3.0])
    assert r1.bounds_active.tolist() == [True, False, True]


def test_weights_choose_the_cheap_input():
    model = HolonomicModel()
    x = np.array([0.0, 0.0, 1.0, 0.0])
    obs = Obstacles.vertical([[3.0, 0.3]], [0.6])
    cheap_lateral = SafetyFilter(model, weights=[100.0, 1.0])
    cheap_brake = SafetyFilter(model, weights=[1.0, 100.0])
    a = cheap_lateral.filter(x, [0.0, 0.0], obs, yaw=0.0).u_safe
    b = cheap_brake.filter(x, [0.0, 0.0], obs, yaw=0.0).u_safe
    assert abs(a[1]) > abs(a[0]) and abs(b[0]) > abs(b[1])


def test_infeasible_is_relaxed_finite_and_within_limits():
    model = HolonomicModel()
    flt = SafetyFilter(model, u_min=[-0.1, -0.1], u_max=[0.1, 0.1])
    x = np.array([0.0, 0.0, 3.0, 0.0])  # 3 m/s straight at an obstacle 1.5 m ahead
    obs = Obstacles.vertical([[1.5, 0.0], [1.6, 0.5]], [0.5, 0.4])
    r = flt.filter(x, [1.0, 0.0], obs, yaw=0.0)
    assert r.status is FilterStatus.RELAXED and r.solver == "active_set"  # DAQP (dense_relaxed_qp)
    assert np.isfinite(r.u_safe).all() and np.all(np.abs(r.u_safe) <= 0.1 + 1e-12)
    assert r.slack.max() > 0 and "infeasible" in r.message
    # It does the most it can: full braking.
    assert r.u_safe[0] == pytest.approx(-0.1, abs=1e-4)
    # One obstacle, closed form outside the box: same.
    r1 = flt.filter(x, [1.0, 0.0], Obstacles.vertical([[1.5, 0.0]], [0.5]), yaw=0.0)
    assert r1.status is FilterStatus.RELAXED and r1.u_safe[0] == pytest.approx(-0.1, abs=1e-4)


def test_emergency_inside_inflated_circle_brakes_and_moves_away():
    model = HolonomicHeightModel()
    flt = SafetyFilter(model, u_min=[-2, -2, -2], u_max=[2, 2, 2])
    x = np.array([0.0, 0.0, 0.5, 0.2, 0.3, 0.0])
    obs = Obstacles.concatenate(
        Obstacles.vertical([[0.3, 0.1]], [0.5]), Obstacles.vertical([[5.0, 5.0]], [0.5])
    )
    r = flt.filter(x, [1.0, 0.0, 0.0], obs, yaw=0.0)
    assert r.status is FilterStatus.EMERGENCY and r.solver == "none"
    assert r.active.tolist() == [True, False]
    assert np.isfinite(r.u_safe).all() and np.isfinite(r.h).all()
    away = -np.array([0.3, 0.1]) / np.linalg.norm([0.3, 0.1])
    acc = r.u_safe[:2]  # yaw 0: body frame == odom
    assert acc @ away > 0  # accelerates away from the centre
    assert acc @ np.array([0.5, 0.2]) < 0  # and against the current velocity
    # Exactly at the centre, unicycle with l = 0 (rank-deficient B): still finite, brakes.
    uni = SafetyFilter(UnicycleModel(0.0), u_min=[-2, -2], u_max=[2, 2])
    r2 = uni.filter([1.0, 1.0, 0.0, 0.8, 0.5], [1.0, 0.0], Obstacles.vertical([[1.0, 1.0]], [0.3]))
    assert r2.status is FilterStatus.EMERGENCY and np.isfinite(r2.u_safe).all()
    assert r2.u_safe[0] < 0 and r2.u_safe[1] < 0  # brakes v and omega


def test_margin_band_uses_true_radius_not_emergency():
    model = HolonomicModel()
    flt = SafetyFilter(model, margin=0.05)
    x = np.array([0.0, 0.0, 0.0, 0.5])
    obs = Obstacles.vertical([[0.52, 0.0]], [0.5])  # 2 cm outside r, inside r + margin
    r = flt.filter(x, [1.0, 0.0], obs, yaw=0.0)
    assert r.status in (FilterStatus.ACTIVE, FilterStatus.INACTIVE)
    assert r.constraint[0] >= -1e-9
    # Barrier reported for the true radius.
    t = c3bf_lie_derivatives(model, x, obs.center, obs.velocity, obs.radius, obs.plane, yaw=0.0)
    assert r.h[0] == pytest.approx(t.h[0])


def test_zero_relative_velocity_is_finite_and_safe():
    """||v_rel|| = 0 (robot at rest next to a static obstacle, or moving with it)."""
    for model, x, vel, yaw in [
        (UnicycleModel(0.2), np.array([0.0, 0.0, 0.0, 0.0, 0.0]), [0.0, 0.0], None),
        (UnicycleModel(0.0), np.array([0.0, 0.0, 0.0, 0.7, 0.0]), [0.7, 0.0], None),
        (HolonomicModel(), np.array([0.0, 0.0, 0.4, -0.3]), [0.4, -0.3], 0.2),
        (XZDoubleIntegratorModel(), np.array([0.0, 0.3, 0.0, 0.0]), [0.0, 0.0], None),
    ]:
        plane = sorted(model.planes)[0]
        obs = Obstacles([[1.0, 0.3 if plane else 0.0]], [vel], [0.6], [plane])
        for v_eps in (DEFAULT_V_EPS, 0.0):
            flt = SafetyFilter(model, v_eps=v_eps, u_min=-np.full(model.n_u, 2.0),
                               u_max=np.full(model.n_u, 2.0))
            u_ref = np.full(model.n_u, 1.0)  # pushes towards the obstacle
            xs, o, dt = x.copy(), obs, 0.002
            for _ in range(1500):
                r = flt.filter(xs, u_ref, o, yaw=yaw)
                assert np.isfinite(r.u_safe).all() and r.status is not FilterStatus.FAILSAFE
                if r.status in (FilterStatus.ACTIVE, FilterStatus.INACTIVE):
                    assert np.all(r.constraint >= -1e-6)
                xs = xs + dt * (model.f(xs, yaw) + model.g(xs, yaw) @ r.u_safe)
                o = o.advanced(dt)
                P = model.point_kinematics(xs, yaw).position[[0, 2] if plane else [0, 1]]
                assert np.linalg.norm(o.center[0] - P) > 0.6


def test_invalid_inputs_raise_catchable_error():
    model = UnicycleHeightModel(0.2)
    flt = SafetyFilter(model)
    x = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.3, 0.0])
    obs = Obstacles.vertical([[2.0, 0.0]], [0.5])
    for bad_x in ([np.nan, 0, 0, 1, 0, 0.3, 0], [0, 0, np.inf, 1, 0, 0.3, 0], [0, 0, 0]):
        with pytest.raises(InvalidInputError):
            flt.filter(bad_x, [0, 0, 0], obs)
    with pytest.raises(InvalidInputError):
        flt.filter(x, [0, np.nan, 0], obs)
    with pytest.raises(InvalidInputError):
        flt.filter(x, [0, 0], obs)
    with pytest.raises(InvalidInputError):
        flt.filter(x, [0, 0, 0], [[2.0, 0.0]])
    with pytest.raises(ValueError):  # InvalidInputError is a ValueError
        flt.filter(x, ["a", 0, 0], obs)
    hol = SafetyFilter(HolonomicModel())
    with pytest.raises(InvalidInputError):
        hol.filter([0, 0, 1, 0], [0, 0], obs)  # yaw missing
    with pytest.raises(InvalidInputError):
        hol.filter([0, 0, 1, 0], [0, 0], obs, yaw=np.nan)
    with pytest.raises(InvalidInputError):  # bars are not supported by the planar model
        hol.filter([0, 0, 1, 0], [0, 0], Obstacles.horizontal([[2.0, 0.3]], 0.2), yaw=0.0)
    for kw in (dict(gamma=0.0), dict(weights=[1.0, -1.0, 1.0]), dict(u_min=[1, 1, 1],
               u_max=[0, 0, 0]), dict(weights=np.ones((3, 3))), dict(margin=-1.0)):
        with pytest.raises(InvalidInputError):
            SafetyFilter(model, **kw)


def test_solver_failure_falls_back_to_brake(monkeypatch):
    model = UnicycleHeightModel(0.2)
    flt = SafetyFilter(model, u_min=[-2, -4, -3], u_max=[2, 4, 3], method="qp")
    x = np.array([0.0, 0.0, 0.0, 1.0, 0.5, 0.3, 0.2])
    obs = Obstacles.vertical([[3.0, 0.1], [3.5, -0.2]], [0.5, 0.5])

    def boom(*args, **kwargs):
        raise RuntimeError("solver exploded")

    monkeypatch.setattr(qp_mod.HardQP, "solve", boom)
    r = flt.filter(x, [1.0, 0.0, 0.0], obs)
    assert r.status is FilterStatus.FAILSAFE and "exploded" in r.message
    np.testing.assert_allclose(r.u_safe, -2.0 * np.array([1.0, 0.5, 0.2]))
    # Absurd numbers beyond the domain (|x| <= 1e9): a clear error naming the entry.
    with pytest.raises(InvalidInputError, match=r"state\[0\] = 1e\+300 is beyond"):
        flt.filter([1e300, -1e300, 0, 1e300, 0, 0, 0], [1e300, 0, 0], obs)
    unbounded = SafetyFilter(model)
    for state in ([0, 0, 0, 1e300, 0, 0.3, 0], [0, 0, 0, 1e200, 1e200, 0.3, 1e200],
                  [1e308, 1e308, 0, -1e308, 0, 0, 0]):
        with pytest.raises(InvalidInputError, match="state"):
            unbounded.filter(state, [1.0, 0.0, 0.0], obs)
    with pytest.raises(InvalidInputError, match="velocity"):
        Obstacles.vertical([[3.0, 0.1]], [0.5], [[1e300, 0.0]])
    # At the edge of the domain: finite, never NaN.
    for state in ([0, 0, 0, 1e9, 0, 0.3, 0], [0, 0, 0, 1e9, 1e9, 0.3, 1e9],
                  [1e9, 1e9, 0, -1e9, 0, 0, 0]):
        for o in (obs, Obstacles.vertical([[3.0, 0.1]], [0.5]), Obstacles.vertical([[3.0, 0.1]],
                  [0.5], [[1e9, 0.0]])):
            r3 = unbounded.filter(state, [1.0, 0.0, 0.0], o)
            assert np.isfinite(r3.u_safe).all(), (state, r3)


def test_osqp_solver_is_reused_per_problem_size(monkeypatch):
    calls = []
    orig = filter_mod.osqp.OSQP.setup

    def counting_setup(self, *a, **k):
        calls.append(1)
        return orig(self, *a, **k)

    monkeypatch.setattr(filter_mod.osqp.OSQP, "setup", counting_setup)
    model = UnicycleHeightModel(0.2)
    flt = SafetyFilter(model, u_min=[-2, -4, -3], u_max=[2, 4, 3], method="qp")
    rng = np.random.default_rng(3)
    for _ in range(20):
        x, u_ref, obs = random_problem(rng, model, 3)
        flt.filter(x, u_ref + np.array([3.0, 0, 0]), obs)
    assert len(calls) <= 2  # hard QP (+ relaxed QP if ever needed) for n = 3
    assert set(flt._qp.hard) == {3}
    flt.reset()
    assert not flt._qp.hard


def test_unverified_osqp_solution_is_resolved_with_tighter_tolerances(monkeypatch):
    model = UnicycleHeightModel(0.2)
    flt = SafetyFilter(model, u_min=[-2, -4, -3], u_max=[2, 4, 3], method="qp")
    rng = np.random.default_rng(8)
    x, u_ref, obs = random_problem(rng, model, 4)
    ref = flt.filter(x, u_ref + np.array([2.0, 0.0, 0.0]), obs)
    calls = []
    orig = SafetyFilter._verify

    def flaky_verify(self, u, Gn, lo_rows):
        calls.append(1)
        return len(calls) > 1 and orig(self, u, Gn, lo_rows)  # reject the first solution

    monkeypatch.setattr(SafetyFilter, "_verify", flaky_verify)
    tightened = []
    orig_tighten = qp_mod.HardQP.tighten
    monkeypatch.setattr(qp_mod.HardQP, "tighten",
                        lambda self, f: (tightened.append(f), orig_tighten(self, f)))
    r = flt.filter(x, u_ref + np.array([2.0, 0.0, 0.0]), obs)
    assert tightened and len(calls) == 2
    assert r.status is ref.status
    np.testing.assert_allclose(r.u_safe, ref.u_safe, atol=1e-6)
    assert flt._qp.hard[4].solver.settings.eps_abs == qp_mod.OSQP_DEFAULTS["eps_abs"]


def test_per_call_limits_override_constructor_limits():
    model = UnicycleHeightModel(0.2)
    wide = SafetyFilter(model, u_min=[-5, -5, -5], u_max=[5, 5, 5])
    rng = np.random.default_rng(21)
    lo, hi = np.array([-1.0, -0.5, -2.0]), np.array([0.8, 0.5, 2.0])
    fixed = SafetyFilter(model, u_min=lo, u_max=hi)
    for n in (1, 1, 3, 5):
        x, u_ref, obs = random_problem(rng, model, n)
        a = wide.filter(x, u_ref, obs, u_min=lo, u_max=hi)
        b = fixed.filter(x, u_ref, obs)
        assert a.status == b.status
        np.testing.assert_allclose(a.u_safe, b.u_safe, atol=1e-7)
        assert np.all((a.u_safe >= lo) & (a.u_safe <= hi))
        # Only one side given: the other comes from the constructor.
        c = wide.filter(x, u_ref, obs, u_max=hi)
        assert np.all(c.u_safe <= hi) and np.all(c.u_safe >= -5)
    with pytest.raises(InvalidInputError):
        wide.filter(x, u_ref, obs, u_min=[1.0, 1.0, 1.0], u_max=[0.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError):
        wide.filter(x, u_ref, obs, u_min=[np.nan, 0.0, 0.0])


def test_unsolvable_hard_qp_falls_back_to_relaxed(monkeypatch):
    model = UnicycleHeightModel(0.2)
    flt = SafetyFilter(model, u_min=[-2, -4, -3], u_max=[2, 4, 3], method="qp")
    rng = np.random.default_rng(8)
    x, u_ref, obs = random_problem(rng, model, 4)
    monkeypatch.setattr(SafetyFilter, "_verify", lambda self, u, Gn, lo: False)
    r = flt.filter(x, u_ref + np.array([2.0, 0.0, 0.0]), obs)
    assert r.status is FilterStatus.RELAXED and "not solved to tolerance" in r.message
    assert np.isfinite(r.u_safe).all() and np.all(r.constraint >= -1e-3)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_fast_and_general_paths_agree(model, monkeypatch):
    """The fast path (``fast_path``: gated rows, DAQP or the closed form) and the general path
    (every clamp and blend) give the same filter output (near, inside, far)."""
    rng = np.random.default_rng(17)
    m = model.n_u
    lo, hi = -np.full(m, 2.0), np.full(m, 2.5)
    yaw = 0.3 if model.needs_yaw else None
    problems = []
    for trial in range(60):
        x, u_ref, obs = random_problem(rng, model, 1 + trial % 12, spread=2.5 + trial % 3)
        if trial % 4 < 2:  # one obstacle in the margin band, or one the body point is inside
            body = model.point_kinematics(x, yaw).position[PLANE_AXES[obs.plane[0]]]
            gap = 0.025 if trial % 4 == 0 else -0.1
            ang = rng.uniform(-np.pi, np.pi)
            c = obs.center.copy()
            c[0] = body + (obs.radius[0] + gap) * np.array([np.cos(ang), np.sin(ang)])
            obs = Obstacles(c, obs.velocity, obs.radius, obs.plane)
        problems.append((x, u_ref * 3.0, obs))
    results = {}
    for fast in (True, False):
        if not fast:
            monkeypatch.setattr(filter_mod, "fast_filter", lambda *args: None)
        flt = SafetyFilter(model, u_min=lo, u_max=hi, margin=0.05)
        results[fast] = [flt.filter(x, u, o, yaw=yaw) for x, u, o in problems]
    seen = set()
    for a, b in zip(*results.values(), strict=True):
        seen.add(a.status)
        assert a.status is b.status and a.solver == b.solver
        np.testing.assert_allclose(a.u_safe, b.u_safe, rtol=1e-9, atol=1e-9)
        for name in ("h", "constraint", "slack"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=1e-9)
        np.testing.assert_array_equal(a.active, b.active)
    assert {FilterStatus.ACTIVE, FilterStatus.EMERGENCY, FilterStatus.RELAXED} <= seen
