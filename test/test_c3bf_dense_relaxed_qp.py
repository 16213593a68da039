"""The filter's relaxed QP on DAQP (dense_relaxed_qp): the KKT point, never a worse cost
than OSQP's relaxed QP (``osqp_qp.RelaxedQP``), rows switched off, warm starts across calls,
and the filter answering RELAXED with it (OSQP only when it finds no optimum)."""

import numpy as np
import pytest
from scipy.optimize import linprog

from safe_legged_c3bf.c3bf import FilterStatus, HolonomicModel, Obstacles, SafetyFilter
from safe_legged_c3bf.c3bf.dense_qp import DAQP_INF
from safe_legged_c3bf.c3bf.dense_relaxed_qp import DenseRelaxedQPs
from safe_legged_c3bf.c3bf.osqp_qp import OSQP_DEFAULTS, RelaxedQP

#: OSQP as the filter runs its relaxed QP (``QPSolvers.relaxed_settings``), polished.
RELAXED_SETTINGS = {**OSQP_DEFAULTS, "eps_abs": 1e-5, "eps_rel": 1e-5, "polishing": True}


def infeasible_problem(rng, n):
    """``n`` unit rows, most of which cannot hold together in a small box; SPD weight."""
    m = int(rng.choice([2, 3, 4]))
    lo, hi = -rng.uniform(0.1, 1.0, m), rng.uniform(0.1, 1.0, m)
    a = rng.normal(size=(n, m))
    a /= np.linalg.norm(a, axis=1)[:, None]
    b = rng.uniform(-0.5, 2.0, n)  # many rows beyond what the box reaches
    L = rng.normal(size=(m, m))
    w = L @ L.T + m * np.eye(m)
    u0 = rng.uniform(-2.0, 2.0, m)
    return w, u0, a, b, lo, hi


def osqp_relaxed(w, rho, u0, a, b, lo, hi):
    """OSQP's relaxed QP as the filter runs it: ``(u clipped, status)``."""
    qp = RelaxedQP(len(b), len(u0), w, rho, RELAXED_SETTINGS)
    u, status = qp.solve(a, b, lo, hi, -(w @ u0))
    return np.clip(u, lo, hi), status


def kkt_residual(w, rho, u0, a, b, lo, hi, u, tol=1e-7):
    """Least L1 residual of the KKT conditions of the relaxed QP at ``u`` (0: optimal).

    With the slack at its best for ``u`` (``d = max(b - a u, 0)``) the problem is the convex
    ``min F(u)`` over the box, ``F = 1/2 (u - u0)^T W (u - u0) + rho sum phi(b_i - a_i u)``,
    ``phi(x) = max(x, 0)^2 + max(x, 0)``. ``u`` is optimal when ``W (u - u0) - a^T s + nu =
    0`` for some ``s_i`` in ``rho phi'(b_i - a_i u)`` (the interval ``[0, rho]`` at a kink)
    and ``nu`` in the box's normal cone at ``u``; a linear program finds the least residual.
    """
    m, n = len(u0), len(b)
    x = b - a @ u
    s_lo = np.where(x > tol, rho * (2.0 * x + 1.0), 0.0)
    s_hi = np.where(x > tol, s_lo, np.where(x < -tol, 0.0, rho))
    at_lo, at_hi = u <= lo + tol, u >= hi - tol
    g = w @ (u - u0)
    # variables: s (n), nu_lo (m, >= 0 at lo), nu_hi (m, >= 0 at hi), r+ (m), r- (m)
    # g - a^T s - nu_lo + nu_hi - r+ + r- = 0; minimise sum(r+ + r-)
    a_eq = np.hstack([-a.T, -np.eye(m), np.eye(m), -np.eye(m), np.eye(m)])
    bounds = ([(lo_i, hi_i) for lo_i, hi_i in zip(s_lo, s_hi, strict=True)]
              + [(0.0, None if at else 0.0) for at in at_lo]
              + [(0.0, None if at else 0.0) for at in at_hi] + [(0.0, None)] * (2 * m))
    c = np.concatenate([np.zeros(n + 2 * m), np.ones(2 * m)])
    res = linprog(c, A_eq=a_eq, b_eq=-g, bounds=bounds, method="highs")
    assert res.status == 0, res.message
    return res.fun / (1.0 + np.abs(g).sum() + rho)


def cost(w, rho, u0, a, b, u):
    d = np.maximum(b - a @ u, 0.0)
    return 0.5 * (u - u0) @ w @ (u - u0) + rho * (d @ d + d.sum())


@pytest.mark.parametrize("n", [1, 2, 5, 12, 40])
def test_the_optimum_of_the_relaxed_qp(n):
    """DAQP's answer meets the KKT conditions and never costs more than OSQP's (which, at the
    filter's settings, can stop at its iteration limit far from it: seed 1, n = 1)."""
    rng = np.random.default_rng(n)
    for _ in range(20):
        w, u0, a, b, lo, hi = infeasible_problem(rng, n)
        rho = 100.0 * float(np.linalg.eigvalsh(w).max())  # the filter's relax_penalty 1e2
        u = DenseRelaxedQPs(w, rho).solve(u0, a, b, lo, hi)
        assert u is not None
        assert np.all(u >= lo) and np.all(u <= hi)
        assert kkt_residual(w, rho, u0, a, b, lo, hi, u) < 1e-9
        u_osqp, _ = osqp_relaxed(w, rho, u0, a, b, lo, hi)
        assert cost(w, rho, u0, a, b, u) <= cost(w, rho, u0, a, b, u_osqp) + 1e-9


def test_osqp_relaxed_can_stop_short_where_daqp_is_exact():
    """The case that shows why: OSQP hits its iteration limit at ~1.8x the optimal cost."""
    w, u0, a, b, lo, hi = infeasible_problem(np.random.default_rng(1), 1)
    rho = 100.0 * float(np.linalg.eigvalsh(w).max())
    u_osqp, status = osqp_relaxed(w, rho, u0, a, b, lo, hi)
    u = DenseRelaxedQPs(w, rho).solve(u0, a, b, lo, hi)
    print(f"\nOSQP status {status}, cost {cost(w, rho, u0, a, b, u_osqp):.1f}; DAQP cost "
          f"{cost(w, rho, u0, a, b, u):.1f}")
    assert cost(w, rho, u0, a, b, u) < 0.9 * cost(w, rho, u0, a, b, u_osqp)
    # the KKT check tells them apart
    assert kkt_residual(w, rho, u0, a, b, lo, hi, u) < 1e-9
    assert kkt_residual(w, rho, u0, a, b, lo, hi, u_osqp) > 1e-3


def test_a_row_switched_off_is_ignored():
    rng = np.random.default_rng(7)
    w, u0, a, b, lo, hi = infeasible_problem(rng, 6)
    rho = 50.0
    off = b.copy()
    off[2] = -DAQP_INF
    keep = np.arange(6) != 2
    u = DenseRelaxedQPs(w, rho).solve(u0, a, off, lo, hi)
    u_without = DenseRelaxedQPs(w, rho).solve(u0, a[keep], b[keep], lo, hi)
    np.testing.assert_allclose(u, u_without, atol=1e-9)


def test_warm_started_calls_match_cold_ones():
    """One workspace per row count, reused: consecutive similar problems give cold answers."""
    rng = np.random.default_rng(3)
    w, u0, a, b, lo, hi = infeasible_problem(rng, 10)
    warm = DenseRelaxedQPs(w, 30.0)
    for k in range(30):
        u0k = u0 + 0.01 * k
        bk = b + 0.005 * np.sin(k)
        np.testing.assert_allclose(warm.solve(u0k, a, bk, lo, hi),
                                   DenseRelaxedQPs(w, 30.0).solve(u0k, a, bk, lo, hi),
                                   atol=1e-9)


def test_rho_must_be_positive():
    with pytest.raises(ValueError, match="rho"):
        DenseRelaxedQPs(np.eye(2), 0.0)


def test_the_filter_answers_relaxed_with_it_and_agrees_with_the_qp_method():
    """Two obstacles the tight limits cannot clear: RELAXED on DAQP ('auto') and on OSQP
    ('qp') give the same input."""
    x = np.array([0.0, 0.0, 3.0, 0.0])
    obs = Obstacles.vertical([[1.5, 0.0], [1.6, 0.5]], [0.5, 0.4])
    results = {}
    for method in ("auto", "qp"):
        flt = SafetyFilter(HolonomicModel(), u_min=[-0.1, -0.1], u_max=[0.1, 0.1],
                           method=method)
        r = flt.filter(x, [1.0, 0.0], obs, yaw=0.0)
        assert r.status is FilterStatus.RELAXED
        results[method] = r
    assert results["auto"].solver == "active_set" and results["qp"].solver == "osqp"
    np.testing.assert_allclose(results["auto"].u_safe, results["qp"].u_safe, atol=1e-4)
