"""The filter's compiled QP (dense_qp, DAQP): OSQP agreement to 1e-9 at 1..250 rows,
infeasibility reported (also after a warm start), warm start used, limits exact."""

import numpy as np
import osqp
import pytest
import scipy.sparse as sp
from test_c3bf_active_set import feasibility_margin

from safe_legged_c3bf.c3bf import (
    FilterStatus,
    Obstacles,
    SafetyFilter,
    UnicycleModel,
    c3bf_lie_derivatives,
)
from safe_legged_c3bf.c3bf.dense_qp import DAQP_INF, DenseQP, DenseQPs, solve_box_qp


def osqp_tight(W, u0, A, b, lo, hi):
    """OSQP, tolerances 1e-12 (polished where it can): ``u``, None unless solved."""
    m = len(u0)
    s = osqp.OSQP()
    s.setup(
        sp.csc_matrix(np.triu(W)), -(W @ u0), sp.csc_matrix(np.vstack([A, np.eye(m)])),
        np.r_[b, lo], np.r_[np.full(len(b), np.inf), hi], verbose=False, eps_abs=1e-12,
        eps_rel=1e-12, eps_prim_inf=1e-14, max_iter=400000, polishing=True,
        polish_refine_iter=20,
    )
    res = s.solve(raise_error=False)
    return res.x if res.info.status == "solved" else None


def feasible_problem(rng, n):
    """``n`` unit rows all holding at an interior point of the box, some tight there; a
    reference that violates several of them; random SPD weight (``m`` = 2 or 3)."""
    m = int(rng.choice([2, 3]))
    lo, hi = -rng.uniform(0.5, 3.0, m), rng.uniform(0.5, 3.0, m)
    u_f = rng.uniform(0.6 * lo, 0.6 * hi)
    A = rng.normal(size=(n, m))
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = A @ u_f - rng.exponential(0.5, n) * (rng.uniform(size=n) > 0.2)
    L = rng.normal(size=(m, m))
    W = L @ L.T + 0.3 * np.eye(m) if rng.uniform() < 0.5 else np.diag(rng.uniform(0.2, 5, m))
    u0 = u_f + rng.normal(size=m) * 3.0
    return W, u0, A, b, lo, hi


@pytest.mark.parametrize("n", [1, 2, 5, 10, 50, 100, 250])
def test_agrees_with_osqp_to_1e9_on_random_feasible_problems(n):
    rng = np.random.default_rng(100 + n)
    compared = 0
    for _ in range(30):
        W, u0, A, b, lo, hi = feasible_problem(rng, n)
        res = solve_box_qp(W, u0, A, b, lo, hi)
        assert res.u is not None and not res.infeasible
        assert (A @ res.u - b >= -1e-10).all()
        assert (res.u >= lo).all() and (res.u <= hi).all()
        ref = osqp_tight(W, u0, A, b, lo, hi)
        if ref is not None:
            np.testing.assert_allclose(res.u, ref, rtol=0, atol=1e-9)
            compared += 1
    assert compared >= 20


def unicycle_clutter(model, x, rng, n):
    """A pillar dead ahead of a unicycle driving +x, plus ``n - 1`` random pillars that its
    velocity does not point at (``h > 1``): mostly feasible, every row carried by the QP."""
    centers, radii = [np.array([[2.5, 0.1]])], [np.array([0.3])]
    have = 1
    while have < n:
        c = rng.uniform(-12, 12, (4 * n, 2))
        r = rng.uniform(0.2, 0.5, 4 * n)
        t = c3bf_lie_derivatives(model, x, c, np.zeros_like(c), r, np.zeros(len(r), int))
        ok = (t.h > 1.0) & (np.hypot(c[:, 0], c[:, 1]) > r + 1.0)
        take = min(n - have, int(ok.sum()))
        centers.append(c[ok][:take])
        radii.append(r[ok][:take])
        have += take
    return Obstacles.vertical(np.concatenate(centers), np.concatenate(radii))


@pytest.mark.parametrize("n", [2, 10, 50, 250])
def test_filter_answers_agree_with_osqp_to_1e9(n):
    """The filter's QP answers (``'active_set'``) against a tight OSQP of the same rows;
    its RELAXED answers against an LP that finds no feasible input."""
    model = UnicycleModel(offset=0.2)
    lo, hi = np.array([-2.0, -4.0]), np.array([2.0, 4.0])
    flt = SafetyFilter(model, u_min=lo, u_max=hi, margin=0.0)
    rng = np.random.default_rng(n)
    x0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0])
    obs = unicycle_clutter(model, x0, rng, n)
    seen = 0
    for _ in range(30):
        x = x0 + rng.normal(scale=0.05, size=5)
        u_ref = rng.uniform([-3, -5], [3, 5])
        r = flt.filter(x, u_ref, obs)
        t = c3bf_lie_derivatives(
            model, x, obs.center, obs.velocity, obs.radius, obs.plane, v_eps=flt.v_eps
        )
        norms = np.linalg.norm(t.lg_h, axis=1)
        A, b = t.lg_h / norms[:, None], -(t.lf_h + flt.gamma * t.h) / norms
        if r.status is FilterStatus.RELAXED:
            assert feasibility_margin(A, b, lo, hi) < 1e-9
        if r.solver != "active_set":
            continue
        seen += 1
        ref = osqp_tight(np.eye(2), u_ref, A, b, lo, hi)
        if ref is not None:
            np.testing.assert_allclose(r.u_safe, ref, rtol=0, atol=1e-9)
    assert seen >= 10


def test_infeasible_problems_are_reported_also_after_a_warm_start():
    rng = np.random.default_rng(3)
    qp = DenseQP(np.eye(2), 3)
    lo, hi = -np.ones(2), np.ones(2)
    for _ in range(50):
        a = rng.normal(size=(3, 2))
        a /= np.linalg.norm(a, axis=1)[:, None]
        feas = qp.solve(np.zeros(2), a, a @ rng.uniform(-0.5, 0.5, 2) - 0.1, lo, hi)
        assert feas.u is not None  # leaves a working set behind
        # Rows 0 and 1 opposite with a gap: no input satisfies both.
        a[1] = -a[0]
        b = np.array([0.3, -0.2, -5.0])
        res = qp.solve(np.zeros(2), a, b, lo, hi)
        assert res.u is None and res.infeasible
    # A row beyond the box.
    res = solve_box_qp(np.eye(2), np.zeros(2), np.array([[1.0, 0.0]]), [1.5], lo, hi)
    assert res.u is None and res.infeasible


def test_infeasible_filter_problem_is_relaxed_with_slacks():
    model = UnicycleModel(offset=0.2)
    flt = SafetyFilter(model, u_min=[-0.1, -0.1], u_max=[0.1, 0.1], margin=0.0)
    # Fast towards a wall of pillars, almost no braking authority.
    obs = Obstacles.vertical([[1.0, y] for y in (-0.6, -0.2, 0.2, 0.6)], [0.3] * 4)
    r = flt.filter([0.0, 0.0, 0.0, 3.0, 0.0], [0.0, 0.0], obs)
    assert r.status is FilterStatus.RELAXED and (r.slack > 0).any()
    assert (r.u_safe >= -0.1).all() and (r.u_safe <= 0.1).all()


def test_warm_start_is_used_and_changes_nothing():
    """Consecutive similar problems: the warm-started workspace needs fewer iterations
    than cold solves in total, with the same answers (to rounding)."""
    rng = np.random.default_rng(5)
    W, u0, A, b, lo, hi = feasible_problem(rng, 50)
    qp = DenseQP(W, 50)
    warm_iters = cold_iters = 0
    for k in range(40):
        du = rng.normal(scale=0.02, size=len(u0))
        db = -np.abs(rng.normal(scale=0.005, size=len(b)))  # looser: stays feasible
        warm = qp.solve(u0 + du, A, b + db, lo, hi)
        cold = solve_box_qp(W, u0 + du, A, b + db, lo, hi)
        np.testing.assert_allclose(warm.u, cold.u, rtol=0, atol=1e-12)
        if k:
            warm_iters += warm.iterations
            cold_iters += cold.iterations
    assert warm_iters < cold_iters


def test_switched_off_rows_and_exact_limits():
    a = np.array([[1.0, 0.0], [0.0, 1.0]])
    res = solve_box_qp(np.eye(2), np.array([3.0, 0.0]), a, [-DAQP_INF, 5.0], -np.ones(2),
                       np.array([2.0, 6.0]))
    assert res.u is not None and res.u[0] == 2.0 and res.u[1] == 5.0  # bit-exact limit


def test_workspaces_per_row_count_are_bounded_and_reset():
    qps = DenseQPs(np.eye(2))
    for n in range(1, 40):
        a = np.tile([1.0, 0.0], (n, 1))
        res = qps.solve(np.zeros(2), a, np.full(n, 0.5), -np.ones(2), np.ones(2))
        np.testing.assert_allclose(res.u, [0.5, 0.0], atol=1e-14)
    assert len(qps._qps) <= 16
    qps.clear()
    assert not qps._qps


def test_no_rows_only_limits_also_on_a_kept_workspace():
    qps = DenseQPs(np.eye(2))
    for u0 in ([3.0, 0.5], [-3.0, 2.0]):
        res = qps.solve(np.array(u0), np.zeros((0, 2)), np.zeros(0), -np.ones(2), np.ones(2))
        np.testing.assert_array_equal(res.u, np.clip(u0, -1.0, 1.0))
