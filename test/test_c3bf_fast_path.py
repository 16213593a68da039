"""The filter's fast path (``fast_path``) against its general path, the obstacle layout it
keeps per ``Obstacles`` object (``rows.PointRows``: a changed set is never missed) and the
re-solved working set (``working_set``) against DAQP."""

import numpy as np
import pytest
from test_c3bf_dense_qp import unicycle_clutter

from safe_legged_c3bf.c3bf import (
    DEFAULT_V_EPS,
    FilterStatus,
    HolonomicModel,
    Obstacles,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleLateralHeightModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
)
from safe_legged_c3bf.c3bf import filter as filter_mod
from safe_legged_c3bf.c3bf.dense_qp import solve_box_qp
from safe_legged_c3bf.c3bf.rows import PointRows
from safe_legged_c3bf.c3bf.working_set import resolve

MODELS = [UnicycleModel(offset=0.2), XZDoubleIntegratorModel(), HolonomicModel(),
          UnicycleHeightModel(offset=0.15), UnicycleLateralHeightModel(offset=0.15)]


def state(model, rng):
    """A state driving +x at 0.5-1.5 m/s near the origin."""
    x = np.zeros(model.n_x)
    for i, s in enumerate(model.state_names):
        x[i] = {"theta": rng.uniform(-0.3, 0.3), "v": rng.uniform(0.5, 1.5),
                "vx": rng.uniform(0.5, 1.5), "z": 0.3}.get(s, rng.uniform(-0.2, 0.2))
    return x


def clutter(model, rng, n):
    """``n`` obstacles ahead and around, the model's planes mixed, some moving."""
    planes = sorted(int(p) for p in model.planes)
    plane = rng.choice(planes, n)
    c = np.c_[rng.uniform(0.8, 6.0, n), rng.uniform(-2.0, 2.0, n)]
    c[plane == 1, 1] = rng.uniform(0.0, 0.6, (plane == 1).sum())
    vel = rng.uniform(-1, 1, (n, 2)) * (rng.uniform(size=(n, 1)) < 0.5)
    return Obstacles(c, vel, rng.uniform(0.2, 0.5, n), plane)


def general(monkeypatch):
    """Switch the fast path off (the general path answers every call)."""
    monkeypatch.setattr(filter_mod, "fast_filter", lambda *args: None)


def same(a, b, tol=1e-9):
    """Two results agree: status, solver, input and every per-row number."""
    assert a.status is b.status and a.solver == b.solver, (a, b)
    np.testing.assert_allclose(a.u_safe, b.u_safe, rtol=tol, atol=tol)
    for name in ("h", "constraint", "slack", "clearance"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=tol, atol=tol)
    np.testing.assert_array_equal(a.active, b.active)
    np.testing.assert_array_equal(a.bounds_active, b.bounds_active)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("setting", ["default", "paper", "weighted"])
def test_fast_path_gives_the_general_paths_answers(model, setting, monkeypatch):
    """Sequences of calls (warm starts), 1-30 obstacles, per-call limits on some calls:
    gamma, W, v_eps and margin varied. Both paths must give the same results."""
    m = model.n_u
    kw = {"default": {}, "paper": {"v_eps": 0.0, "margin": 0.0, "gamma": 1.0},
          "weighted": {"gamma": 0.7, "weights": np.diag(np.linspace(0.5, 2.0, m)) + 0.1}}
    kw = kw[setting]
    lo, hi = -np.full(m, 2.0), np.full(m, 2.5)
    rng = np.random.default_rng(7)
    calls = []
    for k in range(40):
        n = (1, 2, 5, 30)[k % 4]
        obs = clutter(model, rng, n)
        x = state(model, rng)
        for j in range(3):  # the same set again: the kept layout, warm starts
            u_ref = rng.uniform(-2.5, 2.5, m)
            limits = {} if j else {"u_min": lo * 0.8, "u_max": hi * 0.6}
            calls.append((x + rng.normal(scale=0.01, size=len(x)), u_ref, obs, limits))
    yaw = 0.2 if model.needs_yaw else None
    results = []
    for fast in (True, False):
        if not fast:
            general(monkeypatch)
        flt = SafetyFilter(model, u_min=lo, u_max=hi, **kw)
        results.append([flt.filter(x, u, o, yaw=yaw, **lim) for x, u, o, lim in calls])
    seen = set()
    for a, b in zip(*results, strict=True):
        same(a, b)
        seen.add((a.status, a.solver))
    assert {(FilterStatus.ACTIVE, "active_set"), (FilterStatus.INACTIVE, "none")} <= seen
    if setting != "weighted":  # (a full W moves most closed forms beyond the limits)
        assert (FilterStatus.ACTIVE, "closed_form") in seen


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("v_eps", [DEFAULT_V_EPS, 0.0])
def test_one_obstacle_on_floats_is_the_gated_array_row(model, v_eps):
    """``PointRows.one_row`` (floats) and the gated ``lie.cone_rows`` (arrays) compute the
    same operations: the same numbers, bit for bit."""
    rng = np.random.default_rng(11)
    yaw = 0.4 if model.needs_yaw else None
    checked = 0
    for _ in range(300):
        obs = clutter(model, rng, 1)
        x = state(model, rng)
        point = PointRows(obs, 0.01, v_eps, model.n_u)
        kin = model.point_kinematics_tuple(x.tolist(), yaw)
        row = point.one_row(kin, 1.0)
        Y = point.products(kin)
        t = point.rows(Y, v_eps, point.gate)
        assert (row is None) == (t is None)
        if row is None:
            continue
        h, c0, g, clearance, gap = row
        assert [h, c0, *g, clearance] == [t.h[0], t.rows[0, 0] + t.h[0], *t.rows[1:, 0],
                                          t.clearance[0]]
        assert gap == point.gap(Y)[0]
        checked += 1
    assert checked > 250


def test_a_changed_obstacle_set_is_never_missed():
    """The layout is kept while the same ``Obstacles`` object comes back; any other object
    (same numbers, one centre moved by 1e-9 m, a radius, a velocity, a plane, ``advanced``,
    ``from_validated``, another count) gets its own: every answer equals a fresh filter's."""
    model = UnicycleHeightModel(offset=0.15)
    rng = np.random.default_rng(5)
    base = clutter(model, rng, 8)
    x, u_ref = state(model, rng), np.array([1.5, 0.3, 0.5])

    def variant(k):
        c, v, r, p = (a.copy() for a in (base.center, base.velocity, base.radius, base.plane))
        if k == 1:
            c[3, 1] += 1e-9
        elif k == 2:
            r[0] *= 1.5
        elif k == 3:
            v[2] = (0.5, -0.5)
        elif k == 4:
            p[5] = 1 - p[5]
        elif k == 5:
            return base.advanced(0.3)
        elif k == 6:
            return Obstacles.from_validated(c + 0.05, v, r, p)
        elif k == 7:
            return clutter(model, rng, 3)
        return Obstacles(c, v, r, p)

    flt = SafetyFilter(model, u_min=-np.full(3, 2.0), u_max=np.full(3, 2.0))
    flt.filter(x, u_ref, base)
    kept = flt._point
    assert flt.filter(x, u_ref, base) is not None and flt._point is kept  # same object: kept
    for k in [0, 1, 2, 3, 4, 5, 6, 7, 0, 3, 1]:
        obs = variant(k)
        got = flt.filter(x, u_ref, obs)
        assert flt._point.obs is obs
        fresh = SafetyFilter(model, u_min=-np.full(3, 2.0), u_max=np.full(3, 2.0))
        same(got, fresh.filter(x, u_ref, obs), tol=1e-12)
        same(flt.filter(x, u_ref, base), fresh.filter(x, u_ref, base), tol=1e-12)
    with pytest.raises(ValueError):  # an Obstacles object cannot change under the filter
        base.center[0, 0] = 1.0


def test_working_set_resolves_to_daqps_optimum():
    """``working_set.resolve`` on DAQP's final working set (rows and limits, any SPD W)
    gives DAQP's optimum with multipliers >= 0; a set with a row too many or too few is
    refused (a negative multiplier) or its point breaks a row."""
    rng = np.random.default_rng(9)
    matched = refused = 0
    for _ in range(400):
        m = int(rng.choice([2, 3]))
        n = int(rng.integers(1, 12))
        lo, hi = -rng.uniform(0.3, 2.0, m), rng.uniform(0.3, 2.0, m)
        A = rng.normal(size=(n, m))
        b = A @ rng.uniform(0.5 * lo, 0.5 * hi) - rng.exponential(0.3, n)
        L = rng.normal(size=(m, m))
        W = L @ L.T + 0.5 * np.eye(m) if rng.uniform() < 0.5 else np.eye(m)
        u0 = rng.normal(size=m) * 2.0
        res = solve_box_qp(W, u0, A, b, lo, hi)
        ws = res.active
        if res.u is None or not 0 < len(ws) <= m:
            continue
        T = np.vstack([-b, A.T])  # [c0; G^T]: A u - b >= 0
        w_inv = None if (W == np.eye(m)).all() else np.linalg.inv(W).tolist()
        u, lam = resolve(ws, T, u0.tolist(), lo.tolist(), hi.tolist(), w_inv)
        if u is None:  # only a badly conditioned set (or a multiplier of -0.0) is refused
            assert lam is None or min(lam) > -1e-12
            continue
        np.testing.assert_allclose(u, res.u, rtol=0, atol=1e-12)
        matched += 1
        rows = [i for i in range(n) if i not in ws]
        for wrong in ([*ws[:-1]], [*ws, rows[0]] if rows and len(ws) < m else None):
            if not wrong:
                continue
            u2, lam2 = resolve(tuple(wrong), T, u0.tolist(), lo.tolist(), hi.tolist(), w_inv)
            if u2 is None:
                refused += 1
            else:  # feasible everywhere and multipliers >= 0 would make it the optimum too
                z = A @ u2 - b
                breaks = z.min() < -1e-9 or (u2 < lo - 1e-9).any() or (u2 > hi + 1e-9).any()
                assert breaks or np.allclose(u2, res.u, atol=1e-9)
                refused += breaks
    assert matched > 250 and refused > 50


def test_working_set_shortcut_gives_daqps_answers(monkeypatch):
    """The filter on pillars ahead of a unicycle (N = 10, 50, 250, one or two binding,
    states perturbed every call): with the shortcut (``working_set``) and with DAQP on every
    call, the same answers; the shortcut answers most calls."""
    from safe_legged_c3bf.c3bf import fast_path
    rng = np.random.default_rng(1)
    model = UnicycleModel(offset=0.2)
    lo, hi = np.array([-2.0, -4.0]), np.array([2.0, 4.0])
    x0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0])
    for n in (10, 50, 250):
        obs = Obstacles.concatenate(Obstacles.vertical([[3.0, 0.6]], [0.3]),
                                    unicycle_clutter(model, x0, rng, n - 1))
        xs = x0 + rng.normal(size=(150, 5)) * [0.01, 0.01, 0.01, 0.02, 0.02]
        calls = {"hits": 0}

        def counting(*args, orig=resolve, calls=calls):
            out = orig(*args)
            calls["hits"] += out[0] is not None
            return out

        monkeypatch.setattr(fast_path, "resolve", counting)
        a = SafetyFilter(model, u_min=lo, u_max=hi, margin=0.0, v_eps=0.0)
        ra = [a.filter(x, np.array([1.0, 0.0]), obs) for x in xs]
        monkeypatch.setattr(fast_path, "resolve", lambda *args: (None, None))
        b = SafetyFilter(model, u_min=lo, u_max=hi, margin=0.0, v_eps=0.0)
        rb = [b.filter(x, np.array([1.0, 0.0]), obs) for x in xs]
        for p, q in zip(ra, rb, strict=True):
            same(p, q, tol=1e-12)
        assert sum(r.solver == "active_set" for r in ra) > 100
        assert calls["hits"] > 100
