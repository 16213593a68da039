"""Barrier function, regularisation and geometry containers."""

import numpy as np
import pytest

from safe_legged_c3bf.c3bf import (
    DEFAULT_V_EPS,
    EllipseObstacle,
    InvalidInputError,
    Obstacles,
    Plane,
    c3bf_gradient,
    c3bf_value,
    inflated_radius,
    regularized_speed,
)
from safe_legged_c3bf.c3bf.lie import barrier_terms
from safe_legged_c3bf.c3bf.models import UnicycleHeightModel
from safe_legged_c3bf.c3bf.rows import PointRows


def paper_h(p, v, r):
    """h = <p, v> + ||p|| ||v|| cos(phi), cos(phi) = sqrt(||p||^2 - r^2) / ||p|| (paper)."""
    pn = np.linalg.norm(p)
    return p @ v + pn * np.linalg.norm(v) * np.sqrt(pn**2 - r**2) / pn


def test_value_matches_paper_definition_when_unregularised():
    rng = np.random.default_rng(0)
    for _ in range(500):
        p = rng.uniform(-5, 5, 2)
        r = rng.uniform(0.1, 0.99) * np.linalg.norm(p)
        v = rng.uniform(-3, 3, 2)
        assert c3bf_value(p, v, r, v_eps=0.0) == pytest.approx(paper_h(p, v, r), rel=1e-12)


def test_sign_of_h_is_the_collision_cone():
    """h < 0 iff the relative velocity points into the cone of directions hitting the circle."""
    rng = np.random.default_rng(1)
    for _ in range(2000):
        p = rng.uniform(-5, 5, 2)
        r = rng.uniform(0.1, 0.95) * np.linalg.norm(p)
        v = rng.normal(size=2)
        # Does the ray  robot + t * (-v_rel)  hit the circle?  (v_rel = c_dot - V, so the
        # robot moves relative to the obstacle with -v_rel; the centre is at p from it.)
        d = -v / np.linalg.norm(v)
        t_closest = p @ d
        miss = np.linalg.norm(p - t_closest * d)
        hits = t_closest > 0 and miss < r
        h = c3bf_value(p, v, r, v_eps=0.0)
        if abs(h) > 1e-9:
            assert (h < 0) == hits


def test_regularisation_is_conservative_c2_and_exact_above_eps():
    rng = np.random.default_rng(2)
    p = rng.uniform(1, 5, (2000, 2))
    v = rng.normal(size=(2000, 2)) * 10.0 ** rng.uniform(-6, 1, (2000, 1))
    r = 0.5
    s = np.sqrt((p**2).sum(-1) - r * r)
    vn = np.linalg.norm(v, axis=-1)
    h0 = c3bf_value(p, v, r, v_eps=0.0)
    for eps in (1e-3, DEFAULT_V_EPS, 0.2):
        he = c3bf_value(p, v, r, v_eps=eps)
        assert np.all(he <= h0 + 1e-12)  # {h_eps >= 0} is inside the paper's safe set
        assert np.all(h0 - he <= 0.15 * eps * s + 1e-12)  # and differs by at most 0.15 eps s
        np.testing.assert_array_equal(he[vn >= eps], h0[vn >= eps])  # exact above eps
        n = regularized_speed(v, eps)
        assert np.all((n <= vn + 1e-15) & (n >= 0))
    # n(rho) is C2 across rho = eps and increasing.
    eps = DEFAULT_V_EPS
    rho = np.linspace(0.0, 3 * eps, 30001)
    n = regularized_speed(np.c_[rho, np.zeros_like(rho)], eps)
    h_ = rho[1] - rho[0]
    d1 = (n[2:] - n[:-2]) / (2 * h_)
    d2 = (n[2:] - 2 * n[1:-1] + n[:-2]) / h_**2
    assert np.all(np.diff(n) > 0)
    # No jump in n' or n'' anywhere (C2), in particular at rho = eps (n'' goes 75 -> 0).
    assert np.max(np.abs(np.diff(d1))) < 1e-3 and np.max(np.abs(np.diff(d2))) < 0.1
    # At v_rel = 0: h = 0 and the gradient w.r.t. v is p (finite, non-zero).
    h, dh_dp, dh_dv, _ = c3bf_gradient(p, np.zeros_like(p), r, eps)
    np.testing.assert_array_equal(h, 0.0)
    np.testing.assert_allclose(dh_dv, p)
    np.testing.assert_allclose(dh_dp, 0.0)
    # eps = 0 at v = 0: finite sub-gradient (no NaN).
    h, dh_dp, dh_dv, _ = c3bf_gradient(p, np.zeros_like(p), r, 0.0)
    assert np.isfinite(dh_dv).all() and np.isfinite(dh_dp).all()


def test_gradient_matches_finite_differences():
    rng = np.random.default_rng(3)
    for eps in (0.0, DEFAULT_V_EPS):
        for k in range(400):
            p = rng.uniform(-4, 4, 2)
            r = rng.uniform(0.1, 0.9) * np.linalg.norm(p)
            v = rng.uniform(-3, 3, 2) * (0.03 if k % 2 else 1.0)  # also below eps
            _, gp, gv, _ = c3bf_gradient(p, v, r, eps)
            d = 1e-6
            for i in range(2):
                e = np.zeros(2)
                e[i] = d
                fp = (c3bf_value(p + e, v, r, eps) - c3bf_value(p - e, v, r, eps)) / (2 * d)
                fv = (c3bf_value(p, v + e, r, eps) - c3bf_value(p, v - e, r, eps)) / (2 * d)
                assert gp[i] == pytest.approx(fp, rel=1e-5, abs=1e-6)
                assert gv[i] == pytest.approx(fv, rel=1e-5, abs=1e-6)


def test_filter_rows_match_barrier_terms():
    """The filter's rows of one body point (``rows.PointRows``: coordinate-major products,
    with the gate of the fast path and without) equal the batched ``barrier_terms``."""
    rng = np.random.default_rng(4)
    model = UnicycleHeightModel(offset=0.2)
    gated = 0
    for k in range(300):
        x = rng.uniform(-1, 1, 7)
        n = int(rng.integers(1, 7))
        c = rng.uniform(-5, 5, (n, 2))
        cv = rng.uniform(-2, 2, (n, 2)) * (0.01 if k % 5 == 0 else 1.0)  # some slow rows
        pl = rng.integers(0, 2, n) if k % 3 else np.full(n, k % 2)  # mixed and single plane
        r = rng.uniform(0.1, 0.4, n)
        if k % 7 == 0:  # one row inside its circle
            P = model.point_kinematics(x).position
            c[0] = P[[0, 1 + pl[0]]] + 0.5 * r[0]
        obs = Obstacles(c, cv, r, pl)
        for v_eps in (DEFAULT_V_EPS, 0.0):
            t = barrier_terms(model.point_kinematics(x), obs.center, obs.velocity, obs.radius,
                              obs.plane, v_eps)
            point = PointRows(obs, 0.0, v_eps, 3)
            Y = point.products(model.point_kinematics_tuple(x.tolist()))
            for gate in (None, point.gate):
                got = point.rows(Y, v_eps, gate)
                if got is None:  # a row inside or slow: the gate refuses
                    slow = (t.v_rel**2).sum(-1) < max(v_eps**2, 5e-324)
                    assert (t.clearance < point.gate[0]).any() or slow.any()
                    continue
                gated += gate is not None
                np.testing.assert_allclose(got.h, t.h, rtol=1e-13, atol=1e-13)
                np.testing.assert_allclose(got.rows[0], t.lf_h, rtol=1e-12, atol=1e-12)
                np.testing.assert_allclose(got.rows[1:].T, t.lg_h, rtol=1e-12, atol=1e-12)
                np.testing.assert_allclose(got.clearance, t.clearance, rtol=1e-13, atol=1e-13)
    assert gated > 300


def test_inflated_radius():
    assert inflated_radius(0.3, 0.5, 0.4) == pytest.approx(0.7)
    np.testing.assert_allclose(inflated_radius([0.1, 0.2], [0.3, 0.1], 0.2), [0.4, 0.3])
    with pytest.raises(InvalidInputError):
        inflated_radius(np.nan, 0.1, 0.2)
    with pytest.raises(InvalidInputError):
        inflated_radius(-0.1, 0.1, 0.2)
    with pytest.raises(InvalidInputError):
        inflated_radius(0.0, 0.0, 0.0)


def test_ellipse_obstacles_use_width_for_vertical_and_height_for_horizontal():
    pillar = EllipseObstacle(center=(3.0, 1.0), semi_axes=(0.2, 0.4), velocity=(0.5, 0.0))
    bar = EllipseObstacle(center=(4.0, 0.6), semi_axes=(0.05, 0.03), plane=Plane.HORIZONTAL)
    obs = Obstacles.from_ellipses([pillar, bar], robot_width=0.5, robot_height=0.3)
    np.testing.assert_allclose(obs.radius, [0.4 + 0.25, 0.05 + 0.15])
    np.testing.assert_array_equal(obs.plane, [Plane.VERTICAL, Plane.HORIZONTAL])
    np.testing.assert_allclose(obs.velocity, [[0.5, 0.0], [0.0, 0.0]])
    assert obs.planes_present == {Plane.VERTICAL, Plane.HORIZONTAL}
    assert len(Obstacles.from_ellipses([], 0.5, 0.3)) == 0


def test_obstacles_validation_and_immutability():
    obs = Obstacles.vertical([[1.0, 2.0], [3.0, 4.0]], [0.5, 0.6], [[0.1, 0.0], [0.0, 0.0]])
    with pytest.raises(ValueError):
        obs.center[0, 0] = 5.0
    moved = obs.advanced(2.0)
    np.testing.assert_allclose(moved.center, [[1.2, 2.0], [3.0, 4.0]])
    both = Obstacles.concatenate(obs, Obstacles.horizontal([[2.0, 0.5]], 0.2))
    assert len(both) == 3 and both.plane.tolist() == [0, 0, 1]
    bad = [
        dict(center=[[np.nan, 0.0]], radius=[0.5]),
        dict(center=[[0.0, 0.0]], radius=[0.0]),
        dict(center=[[0.0, 0.0]], radius=[np.inf]),
        dict(center=[[0.0, 0.0, 1.0]], radius=[0.5]),
        dict(center=[[0.0, 0.0]], radius=[0.5, 0.2]),
        dict(center=[[0.0, 0.0]], radius=[0.5], velocity=[[np.inf, 0.0]]),
    ]
    for kw in bad:
        with pytest.raises(InvalidInputError):
            Obstacles.vertical(**kw)
    with pytest.raises(InvalidInputError):
        Obstacles([[0.0, 0.0]], [[0.0, 0.0]], [0.5], [2])
