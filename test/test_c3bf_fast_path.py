"""The filter's fast path (``fast_path``) against its general path, and the obstacle layout
it keeps per ``Obstacles`` object (``rows.PointRows``): a changed set is never missed."""

import numpy as np
import pytest

from safe_legged_c3bf.c3bf import (
    DEFAULT_V_EPS,
    FilterStatus,
    HolonomicModel,
    Obstacles,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
)
from safe_legged_c3bf.c3bf import filter as filter_mod
from safe_legged_c3bf.c3bf.rows import PointRows

MODELS = [UnicycleModel(offset=0.2), XZDoubleIntegratorModel(), HolonomicModel(),
          UnicycleHeightModel(offset=0.15)]


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
