"""Independent oracles for the C3BF edge-case tests, and their own checks.

* :func:`exact_qp`: the filter's QP solved in exact rational arithmetic on the float data
  (KKT enumeration over active sets of linearly independent rows), so references up to
  1e300 or limits of 1e9 cost no accuracy.
* :func:`exact_h`: the paper's barrier (with the documented ``v_eps`` blend) in 80-digit
  decimal arithmetic.
* :func:`complex_h`: the same barrier for complex arguments, for complex-step derivatives
  ``d/dt f(x + t d) = Im f(x + i eps d) / eps``: exact to rounding at any magnitude (no
  difference of nearby numbers), unlike finite differences.
"""

from decimal import Decimal, localcontext
from fractions import Fraction
from itertools import combinations

import numpy as np
from test_c3bf_filter import brute_force_qp


def _solve(K, rhs):
    """Gauss-Jordan on Fractions; None if singular."""
    n = len(rhs)
    M = [list(row) + [r] for row, r in zip(K, rhs, strict=True)]
    for c in range(n):
        piv = next((i for i in range(c, n) if M[i][c] != 0), None)
        if piv is None:
            return None
        M[c], M[piv] = M[piv], M[c]
        inv = 1 / M[c][c]
        M[c] = [v * inv for v in M[c]]
        for i in range(n):
            if i != c and M[i][c] != 0:
                f = M[i][c]
                M[i] = [a - f * b for a, b in zip(M[i], M[c], strict=True)]
    return [M[i][n] for i in range(n)]


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b, strict=True))


def exact_qp(W, u0, A, b, lo, hi):
    """Exact ``argmin (u-u0)'W(u-u0)`` s.t. ``A u >= b``, ``lo <= u <= hi`` (float data taken
    exactly): a list of Fractions, or None if infeasible."""
    m = len(u0)
    F = Fraction
    A = np.asarray(A, float).reshape(-1, m)
    rows = [([F(x) for x in a], F(bi)) for a, bi in zip(A.tolist(), np.ravel(b).tolist(),
                                                         strict=True)]
    for i in range(m):
        e = [F(int(j == i)) for j in range(m)]
        if np.isfinite(lo[i]):
            rows.append((e, F(float(lo[i]))))
        if np.isfinite(hi[i]):
            rows.append(([-x for x in e], F(-float(hi[i]))))
    Wq = [[F(x) for x in r] for r in np.asarray(W, float).tolist()]
    cols = [_solve(Wq, [F(int(i == j)) for i in range(m)]) for j in range(m)]  # W^-1 e_j
    uq = [F(x) for x in np.asarray(u0, float).tolist()]

    def feasible(u):
        return all(_dot(a, u) >= bi for a, bi in rows)

    if feasible(uq):
        return uq
    va = [[sum(a[j] * cols[j][i] for j in range(m)) for i in range(m)] for a, _ in rows]
    for k in range(1, m + 1):
        for S in combinations(range(len(rows)), k):
            K = [[_dot(rows[i][0], va[j]) for j in S] for i in S]
            lam = _solve(K, [rows[i][1] - _dot(rows[i][0], uq) for i in S])
            if lam is None or any(x < 0 for x in lam):
                continue
            u = [uq[t] + sum(x * va[j][t] for x, j in zip(lam, S, strict=True))
                 for t in range(m)]
            if feasible(u):
                return u
    return None


def as_float(u):
    return None if u is None else np.array([float(x) for x in u])


def _n_eps(vv, v_eps, sqrt):
    """The documented regularised speed from ``vv = ||v||^2`` (any number type)."""
    if v_eps > 0 and vv.real < v_eps * v_eps:
        u = vv / (v_eps * v_eps)
        return v_eps * u * (type(u)(15) / 8 - type(u)(5) / 4 * u + type(u)(3) / 8 * u * u)
    return sqrt(vv)


def exact_h(p, v, r, v_eps):
    """``<p, v> + n_eps(v) sqrt(max(|p|^2 - r^2, 0))`` in 80-digit decimal arithmetic."""
    with localcontext() as ctx:
        ctx.prec = 80
        P = [Decimal(float(x)) for x in p]
        V = [Decimal(float(x)) for x in v]
        R, E = Decimal(float(r)), Decimal(float(v_eps))
        ss = max(_dot(P, P) - R * R, Decimal(0))
        n = _n_eps(_dot(V, V), E, lambda z: z.sqrt())
        return float(_dot(P, V) + n * ss.sqrt())


def exact_speed(v, v_eps):
    """The regularised speed ``n_eps(||v||)`` in 80-digit decimal arithmetic."""
    with localcontext() as ctx:
        ctx.prec = 80
        V = [Decimal(float(x)) for x in v]
        return float(_n_eps(_dot(V, V), Decimal(float(v_eps)), lambda z: z.sqrt()))


def complex_h(p, v, r, v_eps):
    """The barrier for complex ``p``, ``v`` (``(..., 2)``): analytic away from the clamps."""
    pp = (p * p).sum(-1)
    vv = (v * v).sum(-1)
    s = np.sqrt(pp - r * r)
    if v_eps > 0:
        small = vv.real < v_eps**2
        u = np.where(small, vv, 0.0) / v_eps**2  # (no overflow in the unused branch)
        n = np.where(small, v_eps * u * (1.875 - 1.25 * u + 0.375 * u * u), np.sqrt(vv))
    else:
        n = np.sqrt(vv)
    return (p * v).sum(-1) + n * s


def complex_step(f, x, d, eps=1e-200):
    """Directional derivative of ``f`` at ``x`` along ``d`` by the complex step."""
    return np.imag(f(x + 1j * eps * d)) / eps


# ------------------------------------------------------------------ the oracles' own checks
def test_exact_qp_agrees_with_the_brute_force_on_ordinary_problems():
    rng = np.random.default_rng(5)
    for _ in range(150):
        m = int(rng.choice([2, 3]))
        A = rng.normal(size=(int(rng.integers(0, 4)), m))
        b = rng.normal(size=len(A))
        L = rng.normal(size=(m, m))
        W = L @ L.T + 0.5 * np.eye(m)
        lo, hi = -rng.uniform(0.3, 3.0, m), rng.uniform(0.3, 3.0, m)
        u0 = rng.normal(size=m) * 3
        u_bf, _ = brute_force_qp(A, b, u0, W, lo, hi)
        u_ex = as_float(exact_qp(W, u0, A, b, lo, hi))
        assert (u_bf is None) == (u_ex is None)
        if u_ex is not None:
            np.testing.assert_allclose(u_ex, u_bf, atol=1e-9)


def test_exact_qp_is_exact_for_a_far_reference():
    u = exact_qp(np.eye(2), [1e17, 0.5], np.zeros((0, 2)), [], [-2, -2], [2, 2])
    assert u == [2, Fraction(1, 2)]


def test_exact_and_complex_h_agree_with_the_paper_formula():
    rng = np.random.default_rng(6)
    for _ in range(200):
        p = rng.uniform(-4, 4, 2)
        r = rng.uniform(0.1, 0.9) * np.linalg.norm(p)
        v = rng.uniform(-3, 3, 2)
        paper = p @ v + np.linalg.norm(v) * np.sqrt(p @ p - r * r)
        scale = np.linalg.norm(p) * np.linalg.norm(v)
        assert abs(exact_h(p, v, r, 0.0) - paper) <= 1e-14 * scale
        assert abs(complex_h(p + 0j, v + 0j, r, 0.0).real - paper) <= 1e-14 * scale
        # complex step of h along v: <p + s v / |v|, d>
        d = rng.normal(size=2)
        s = np.sqrt(p @ p - r * r)
        expected = (p + s * v / np.linalg.norm(v)) @ d
        got = complex_step(lambda z, p=p, r=r: complex_h(p + 0j, z, r, 0.0), v, d)
        assert abs(got - expected) <= 1e-12 * (1 + abs(expected))
