"""The exact active-set QP solver (DAQP): against brute-force KKT enumeration, OSQP and an LP."""

import numpy as np
import osqp
import pytest
import scipy.sparse as sp
from scipy.optimize import linprog
from test_c3bf_filter import brute_force_qp

from safe_legged_c3bf.c3bf.dense_qp import solve_box_qp


def osqp_reference(W, u0, A, b, lo, hi):
    """OSQP with tight tolerances: (u, status string)."""
    m = len(u0)
    solver = osqp.OSQP()
    solver.setup(
        sp.csc_matrix(np.triu(W)), -(W @ u0), sp.csc_matrix(np.vstack([A, np.eye(m)])),
        np.r_[b, lo], np.r_[np.full(len(b), np.inf), hi], verbose=False, eps_abs=1e-10,
        eps_rel=1e-10, eps_prim_inf=1e-12, max_iter=200000, polishing=True,
    )
    res = solver.solve(raise_error=False)
    return res.x, res.info.status


def feasibility_margin(A, b, lo, hi):
    """max t s.t. A u - b >= t, lo <= u <= hi, t <= 1 (HiGHS); < 0 means infeasible."""
    m = A.shape[1]
    res = linprog(
        c=np.r_[np.zeros(m), -1.0], A_ub=np.c_[-A, np.ones(len(b))], b_ub=-b,
        bounds=[(lo_ if np.isfinite(lo_) else None, hi_ if np.isfinite(hi_) else None)
                for lo_, hi_ in zip(lo, hi, strict=True)] + [(None, 1.0)],
        method="highs",
    )
    assert res.status == 0
    return -res.fun


def random_problem(rng, trial):
    m = int(rng.choice([2, 3]))
    k = int(rng.integers(1, 11))
    A = rng.normal(size=(k, m))
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = rng.normal(size=k) * rng.choice([0.1, 0.3, 1.0])
    if trial % 5 == 0 and k > 1:  # duplicate or parallel rows
        A[1] = A[0]
        b[1] = b[0] - rng.choice([0.0, 1e-3])
    if trial % 9 == 0:  # a row that repeats a bound
        A[0] = np.eye(m)[0]
    if trial % 2:
        L = rng.normal(size=(m, m))
        W = L @ L.T + 0.5 * np.eye(m)
    else:
        W = np.diag(rng.uniform(0.2, 5.0, m))
    lo, hi = -rng.uniform(0.3, 3.0, m), rng.uniform(0.3, 3.0, m)
    if trial % 7 == 0:
        lo[0] = -np.inf
    if trial % 13 == 0:
        hi[-1] = np.inf
    if trial % 11 == 0:
        lo[1] = hi[1] = 0.2  # a fixed input
    u0 = rng.normal(size=m) * 2.0  # often outside the box
    return W, u0, A, b, lo, hi


def test_matches_brute_force_and_osqp_on_random_problems():
    rng = np.random.default_rng(7)
    counts = {"optimum": 0, "infeasible": 0}
    for trial in range(400):
        W, u0, A, b, lo, hi = random_problem(rng, trial)
        res = solve_box_qp(W, u0, A, b, lo, hi)
        u_bf, cost_bf = brute_force_qp(A, b, u0, W, lo, hi)
        u_osqp, status = osqp_reference(W, u0, A, b, lo, hi)
        if res.u is None:
            assert res.infeasible, trial  # never "unknown" on these problems
            assert u_bf is None, trial
            assert status == "primal infeasible", trial
            counts["infeasible"] += 1
            continue
        counts["optimum"] += 1
        u = res.u
        assert u_bf is not None, trial
        assert np.all(A @ u - b >= -1e-9) and np.all(u >= lo - 1e-9) and np.all(u <= hi + 1e-9)
        cost = (u - u0) @ W @ (u - u0)
        assert cost <= cost_bf + 1e-9 * (1.0 + cost_bf), trial
        np.testing.assert_allclose(u, u_bf, atol=1e-7)
        if status == "solved":
            np.testing.assert_allclose(u, u_osqp, atol=1e-6)
    assert min(counts.values()) > 80, counts  # both outcomes well represented


def test_infeasibility_certificates_agree_with_an_lp():
    rng = np.random.default_rng(11)
    for trial in range(300):
        W, u0, A, b, lo, hi = random_problem(rng, trial)
        res = solve_box_qp(W, u0, A, b, lo, hi)
        t = feasibility_margin(A, b, lo, hi)
        if res.infeasible:
            assert t < 1e-9, trial
        else:
            assert res.u is not None and t > -1e-9, trial


def test_feasible_reference_is_returned_unchanged():
    A = np.array([[1.0, 0.0], [0.0, 1.0]])
    u0 = np.array([0.5, 0.5])
    res = solve_box_qp(np.eye(2), u0, A, np.zeros(2), -np.ones(2), np.ones(2))
    np.testing.assert_array_equal(res.u, u0)
    assert not res.infeasible


def test_degenerate_vertex_with_more_active_rows_than_inputs():
    # Four rows through the point (1, 1) plus the bound u <= 1: a degenerate optimum.
    A = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 2.0]])
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = A @ np.array([1.0, 1.0])
    for u0 in ([0.0, 0.0], [-3.0, 0.2], [0.9, -2.0]):
        res = solve_box_qp(np.eye(2), np.array(u0), A, b, -np.full(2, 5.0), np.ones(2))
        np.testing.assert_allclose(res.u, [1.0, 1.0], atol=1e-12)


@pytest.mark.parametrize("w", [np.eye(3), np.diag([1.0, 0.2, 0.5])])
def test_single_row_is_the_closed_form(w):
    a = np.array([[0.6, 0.0, 0.8]])
    u0 = np.array([0.1, 0.2, -0.3])
    res = solve_box_qp(w, u0, a, np.array([1.0]), -np.full(3, 9.0), np.full(3, 9.0))
    w_inv_a = np.linalg.solve(w, a[0])
    expected = u0 + w_inv_a * (1.0 - a[0] @ u0) / (a[0] @ w_inv_a)
    np.testing.assert_allclose(res.u, expected, rtol=1e-12, atol=1e-12)


def test_opposite_rows_without_room_are_infeasible():
    A = np.array([[1.0, 0.0], [-1.0, 0.0]])
    res = solve_box_qp(np.eye(2), np.zeros(2), A, np.array([0.5, -0.4]), -np.ones(2), np.ones(2))
    assert res.u is None and res.infeasible
    # A row beyond the box.
    res = solve_box_qp(np.eye(2), np.zeros(2), A[:1], np.array([1.5]), -np.ones(2), np.ones(2))
    assert res.u is None and res.infeasible


def test_warm_start_from_any_rows_gives_the_same_optimum():
    """The previous active rows, random rows, dependent or out-of-range rows: the solver
    either starts from them (only if dual feasible) or ignores them; the answer is the same."""
    rng = np.random.default_rng(13)
    warm_used = 0
    for trial in range(400):
        W, u0, A, b, lo, hi = random_problem(rng, trial)
        cold = solve_box_qp(W, u0, A, b, lo, hi)
        n_rows = len(b) + np.isfinite(lo).sum() + np.isfinite(hi).sum()
        candidates = [
            cold.active,  # the exact optimum's active rows: no step needed
            tuple(rng.integers(0, n_rows, rng.integers(1, 4)).tolist()),
            (0, 0, 1),
            (n_rows + 3,),
        ]
        # A neighbouring problem warm-started from this one's active set (the filter's use).
        u0_next = u0 + rng.normal(scale=0.05, size=u0.shape)
        b_next = b + rng.normal(scale=0.01, size=b.shape)
        ref_next = solve_box_qp(W, u0_next, A, b_next, lo, hi)
        got_next = solve_box_qp(W, u0_next, A, b_next, lo, hi, warm=cold.active)
        for ref, got in [(ref_next, got_next)] + [
            (cold, solve_box_qp(W, u0, A, b, lo, hi, warm=w)) for w in candidates
        ]:
            assert got.infeasible == ref.infeasible, trial
            assert (got.u is None) == (ref.u is None), trial
            if ref.u is not None:
                np.testing.assert_allclose(got.u, ref.u, atol=1e-9)
        warm_used += bool(cold.active) and cold.u is not None
    assert warm_used > 100
