"""Edge cases of the C3BF library (issue #14): solver statuses, extreme inputs, inside an
obstacle, validation of ellipses, and the documented defaults."""

import numpy as np
import osqp
import pytest
from test_c3bf_oracle import as_float, exact_qp

from safe_legged_c3bf.c3bf import (
    EllipseObstacle,
    FilterStatus,
    HolonomicHeightModel,
    HolonomicModel,
    InvalidInputError,
    Obstacles,
    Plane,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleLateralHeightModel,
    UnicycleLateralModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
    c3bf_lie_derivatives,
)
from safe_legged_c3bf.c3bf import osqp_qp as qp_mod
from safe_legged_c3bf.c3bf.dense_relaxed_qp import DenseRelaxedQPs
from safe_legged_c3bf.c3bf.domain import REF_RATIO_MAX
from safe_legged_c3bf.c3bf.inside import radial_terms
from safe_legged_c3bf.c3bf.lie import PLANE_AXES
from safe_legged_c3bf.c3bf.solver_status import OSQP_STATUS_WORDS, describe_osqp_status

UH_MIN, UH_MAX = [-2.0, -4.0, -3.0], [2.0, 4.0, 3.0]
X_UH = np.array([0.0, 0.0, 0.0, 1.0, 0.5, 0.3, 0.2])


# ---------------------------------------------------------------- OSQP status in words
def test_every_osqp_status_has_words():
    for status in osqp.SolverStatus:
        text = describe_osqp_status(status.value)
        assert OSQP_STATUS_WORDS[int(status)] in text
        assert f"OSQP status {int(status)}, {status.name}" in text
    assert "unknown" in describe_osqp_status("x")


@pytest.mark.parametrize("code", [int(s) for s in osqp.SolverStatus])
def test_filter_messages_name_the_osqp_status_in_words(code, monkeypatch):
    """Whatever OSQP answers, a message that mentions it says what the code means."""
    flt = SafetyFilter(UnicycleHeightModel(0.2), u_min=UH_MIN, u_max=UH_MAX, method="qp")
    obs = Obstacles.vertical([[3.0, 0.1], [3.5, -0.2]], [0.5, 0.5])
    ok = np.array([-0.5, 0.0, 0.0])

    def fake_solve(self, *args, **kwargs):
        return ok.copy(), code

    monkeypatch.setattr(qp_mod.HardQP, "solve", fake_solve)
    monkeypatch.setattr(qp_mod.RelaxedQP, "solve", fake_solve)
    monkeypatch.setattr(SafetyFilter, "_verify", lambda self, *a: False)
    r = flt.filter(X_UH, [1.0, 0.0, 0.0], obs)
    assert np.isfinite(r.u_safe).all()
    if "OSQP" in r.message:
        assert OSQP_STATUS_WORDS[code] in r.message, r.message
    if r.status is FilterStatus.FAILSAFE:
        assert "OSQP" in r.message, r.message


# ---------------------------------------------------------------- extreme references
def _holonomic_and_unicycle():
    return [(HolonomicModel(), np.array([0.0, 0.0, 0.5, 0.0]), 0.0),
            (UnicycleModel(0.2), np.array([0.0, 0.0, 0.0, 0.5, 0.0]), None)]


@pytest.mark.parametrize("method", ["auto", "qp"])
def test_huge_reference_without_obstacles_is_clipped_exactly(method):
    """Issue #14: u_ref = [1e17, 0.5] gave [0, 0.5] (auto) or [2, 3e-14] (qp)."""
    for model, x, yaw in _holonomic_and_unicycle():
        flt = SafetyFilter(model, u_min=[-2, -2], u_max=[2, 2], method=method)
        for u_ref, expected in (([1e17, 0.5], [2.0, 0.5]), ([1e300, -1e300], [2.0, -2.0]),
                                ([-3e8, 1.5], [-2.0, 1.5])):
            r = flt.filter(x, u_ref, Obstacles.empty(), yaw=yaw)
            assert r.status is FilterStatus.ACTIVE, r
            np.testing.assert_array_equal(r.u_safe, expected)
        # A far obstacle whose constraint the clipped reference satisfies: still exact.
        far_obs = Obstacles.vertical([[30.0, 30.0]], [0.5])
        r = flt.filter(x, [1e17, 0.5], far_obs, yaw=yaw)
        np.testing.assert_array_equal(r.u_safe, [2.0, 0.5])


@pytest.mark.parametrize("method", ["auto", "qp"])
def test_huge_reference_against_a_binding_obstacle_is_refused(method):
    """Issue #14: 1e300 with an obstacle gave FAILSAFE 'OSQP status 9'. The clip is not the
    optimum there (the obstacle binds), and rounding would dominate the QP: refused."""
    for model, x, yaw in _holonomic_and_unicycle():
        flt = SafetyFilter(model, u_min=[-2, -2], u_max=[2, 2], method=method)
        obs = Obstacles.vertical([[1.5, 0.1]], [0.5])
        with pytest.raises(InvalidInputError, match=r"u_ref\[0\] = 1e\+300 is beyond 1e\+03"):
            flt.filter(x, [1e300, 0.5], obs, yaw=yaw)
    # A non-diagonal weight: the W-projection onto the box is not the clip: refused.
    flt = SafetyFilter(HolonomicModel(), weights=[[2.0, 1.0], [1.0, 2.0]], u_min=[-2, -2],
                       u_max=[2, 2], method=method)
    with pytest.raises(InvalidInputError, match="u_ref"):
        flt.filter([0, 0, 0.5, 0], [1e17, 0.5], Obstacles.empty(), yaw=0.0)


@pytest.mark.parametrize("method", ["auto", "qp"])
def test_references_up_to_the_bound_give_the_exact_optimum(method):
    """Within REF_RATIO_MAX x the input scale the answer matches exact rational arithmetic."""
    rng = np.random.default_rng(14)
    model = UnicycleHeightModel(0.2)
    lo, hi = np.array(UH_MIN), np.array(UH_MAX)
    flt = SafetyFilter(model, u_min=lo, u_max=hi, margin=0.0, method=method)
    bound = REF_RATIO_MAX * (1 + 4.0)
    for _ in range(30):
        obs = Obstacles.vertical(rng.uniform([1.0, -1.0], [3.0, 1.0], (2, 2)), [0.4, 0.5])
        d = rng.normal(size=3)
        u_ref = 0.99 * bound * d / np.abs(d).max()
        r = flt.filter(X_UH, u_ref, obs)
        t = c3bf_lie_derivatives(model, X_UH, obs.center, obs.velocity, obs.radius, obs.plane)
        u_ex = as_float(exact_qp(np.eye(3), u_ref, t.lg_h, -(t.lf_h + t.h), lo, hi))
        if u_ex is None:
            assert r.status is FilterStatus.RELAXED
        else:
            assert r.status is FilterStatus.ACTIVE
            np.testing.assert_allclose(r.u_safe, u_ex, atol=1e-8)


@pytest.mark.parametrize("method", ["auto", "qp"])
def test_large_limits_and_references_are_verified_to_their_own_scale(method):
    """Limits of 1e8 and a reference of 4e10 (within the bound): the row check of the
    answer must allow the rounding of numbers of that size (it used to reject the exact
    answer, and OSQP's too, and report a feasible problem as RELAXED with garbage)."""
    model = HolonomicModel()
    x = np.array([0.0, 0.0, 0.44432961628423495, -0.5625691508623909])
    obs = Obstacles.vertical([[1.4079369133410473, 2.147852743556959],
                              [0.6673931713750224, 1.4855446101490037]], [0.5, 0.5])
    lim = 108348235.89623432
    u_ref = np.array([-1664754989.6612976, 44362008949.58992])
    flt = SafetyFilter(model, u_min=[-lim, -lim], u_max=[lim, lim], margin=0.0, method=method)
    r = flt.filter(x, u_ref, obs, yaw=0.0)
    t = c3bf_lie_derivatives(model, x, obs.center, obs.velocity, obs.radius, obs.plane,
                             yaw=0.0)
    u_ex = as_float(exact_qp(np.eye(2), u_ref, t.lg_h, -(t.lf_h + t.h), [-lim] * 2, [lim] * 2))
    assert r.status is FilterStatus.ACTIVE, r.message
    # Exact for data moved by ~eps |u_ref| (the active-set method works in u - u_ref).
    np.testing.assert_allclose(r.u_safe, u_ex, atol=1e-12 * np.abs(u_ref).max())


def test_osqp_iteration_limit_is_not_reported_as_the_optimum():
    """Thin feasible slabs made OSQP stop at its iteration limit: the iterate was returned as
    ACTIVE (off by 6e-3), or the feasible problem as RELAXED. Both now give the optimum."""
    model = XZDoubleIntegratorModel()
    x = np.array([-5.0, 0.1, 0.0, -0.4])
    for centers, u_ref in (([[-5.83229367, -1.71859485], [-3.91939539, -1.58294197]],
                            [-3.5, -3.5]),
                           ([[-5.71708043, -1.76702856], [-0.25705832, -9.82494354]],
                            [-3.5, 3.5])):
        obs = Obstacles.horizontal(centers, [1.0, 1.0])
        flt = SafetyFilter(model, gamma=0.5, weights=[0.2, 0.2], u_min=[-0.3, -0.3],
                           u_max=[0.3, 0.3], margin=0.0, method="qp")
        r = flt.filter(x, u_ref, obs)
        t = c3bf_lie_derivatives(model, x, obs.center, obs.velocity, obs.radius, obs.plane)
        u_ex = as_float(exact_qp(np.eye(2) * 0.2, u_ref, t.lg_h, -(t.lf_h + 0.5 * t.h),
                                 [-0.3, -0.3], [0.3, 0.3]))
        assert r.status is FilterStatus.ACTIVE, r.message
        np.testing.assert_allclose(r.u_safe, u_ex, atol=1e-8)


# ---------------------------------------------------------------- the numeric domain
def test_states_limits_and_parameters_outside_the_domain_are_named():
    flt = SafetyFilter(UnicycleHeightModel(0.2), u_min=UH_MIN, u_max=UH_MAX)
    obs = Obstacles.vertical([[3.0, 0.1]], [0.5])
    x = X_UH.copy()
    x[3] = 2e9
    with pytest.raises(InvalidInputError, match=r"state\[3\] = 2000000000.0 is beyond"):
        flt.filter(x, [0, 0, 0], obs)
    with pytest.raises(InvalidInputError, match=r"u_ref\[1\] = nan is not finite"):
        flt.filter(X_UH, [0, np.nan, 0], obs)
    with pytest.raises(InvalidInputError, match="finite input limits"):
        flt.filter(X_UH, [0, 0, 0], obs, u_max=[1e10, 1, 1])
    flt.filter(X_UH, [0, 0, 0], obs, u_max=[np.inf, 1, 1])  # open limits are fine
    hol = SafetyFilter(HolonomicModel())
    with pytest.raises(InvalidInputError, match="yaw = 1e"):
        hol.filter([0, 0, 1, 0], [0, 0], obs, yaw=1e300)
    for kw in ("brake_gain", "escape_accel", "relax_penalty", "exit_speed", "gamma", "v_eps"):
        with pytest.raises(InvalidInputError, match=kw):
            SafetyFilter(HolonomicModel(), **{kw: np.nan})
    with pytest.raises(InvalidInputError, match="weights"):
        SafetyFilter(HolonomicModel(), weights=[1.0, 1e300])


def test_models_validate_offset_state_yaw_and_gain():
    with pytest.raises(InvalidInputError, match="offset"):
        UnicycleModel(offset=np.nan)
    with pytest.raises(InvalidInputError, match="offset"):
        UnicycleHeightModel(offset=1e10)
    assert UnicycleModel(offset=1).offset == 1.0
    with pytest.raises(InvalidInputError, match=r"state\[1, 2\] = inf"):
        UnicycleModel().f(np.array([[0, 0, 0, 1, 0], [0, 0, np.inf, 1, 0]]))
    with pytest.raises(InvalidInputError, match="yaw"):
        HolonomicModel().g([0, 0, 1, 0], yaw=np.nan)
    with pytest.raises(InvalidInputError, match="gain"):
        HolonomicModel().brake_input([0, 0, 1, 0], yaw=0.0, gain=-1.0)


def test_ellipse_obstacle_is_validated_at_construction():
    good = EllipseObstacle(center=(1, 2), semi_axes=(0.3, 0.2), velocity=(0, 1), plane=1)
    assert good.center == (1.0, 2.0) and good.plane is Plane.HORIZONTAL
    bad = [
        (dict(center=(np.nan, 0.0)), r"center\[0\] = nan is not finite"),
        (dict(center=(0.0, 1e300)), r"center\[1\] = 1e\+300 is beyond"),
        (dict(center=(0.0, 0.0, 1.0)), "center must be 2 numbers"),
        (dict(semi_axes=(0.3, 0.0)), r"semi_axes\[1\] = 0.0 must be > 0"),
        (dict(semi_axes=(-0.3, 0.2)), r"semi_axes\[0\] = -0.3 must be > 0"),
        (dict(semi_axes="ab"), "semi_axes must be 2 numbers"),
        (dict(velocity=(np.inf, 0.0)), r"velocity\[0\] = inf is not finite"),
        (dict(plane=2), "plane = 2 is not Plane.VERTICAL"),
    ]
    for kw, message in bad:
        args = dict(center=(1.0, 2.0), semi_axes=(0.3, 0.2)) | kw
        with pytest.raises(InvalidInputError, match=message) as err:
            EllipseObstacle(**args)
        assert "EllipseObstacle(center=" in str(err.value)  # names the obstacle
    with pytest.raises(InvalidInputError, match=r"obstacle 1: .* is not an EllipseObstacle"):
        Obstacles.from_ellipses([good, (1.0, 2.0)], 0.4, 0.3)


def test_obstacle_errors_name_the_obstacle_and_the_value():
    with pytest.raises(InvalidInputError, match=r"obstacle 1: center\[1\] = inf is not finite"):
        Obstacles.vertical([[0.0, 0.0], [1.0, np.inf]], [0.5, 0.5])
    with pytest.raises(InvalidInputError, match=r"obstacle 0: radius = -1.0 must be > 0"):
        Obstacles.vertical([[0.0, 0.0], [1.0, 1.0]], [-1.0, 0.5])
    with pytest.raises(InvalidInputError, match=r"obstacle 1: velocity\[0\] = 1\d+\.0 is beyond"):
        Obstacles.vertical([[0.0, 0.0], [1.0, 1.0]], [0.5, 0.5], [[0.0, 0.0], [1e10, 0.0]])
    with pytest.raises(InvalidInputError, match="obstacle 0: plane = 3"):
        Obstacles([[0.0, 0.0]], [[0.0, 0.0]], [1.0], [3])
    with pytest.raises(InvalidInputError, match="dt"):
        Obstacles.vertical([[0.0, 0.0]], [0.5]).advanced(np.nan)


# ---------------------------------------------------------------- inside an obstacle
def _inside_cases():
    """(name, state, u_ref): a holonomic robot whose body point (0, 0) is inside a circle of
    radius 0.5 centred at (0.3, 0) (yaw 0: body frame == odom)."""
    return [
        ("leaving", [0.0, 0.0, -0.5, 0.1], [0.0, 0.0]),
        ("going deeper", [0.0, 0.0, 0.5, 0.2], [1.0, 0.0]),
        ("at rest", [0.0, 0.0, 0.0, 0.0], [0.0, 0.0]),
        ("at the centre", [0.3, 0.0, 0.2, 0.0], [0.0, 0.0]),
    ]


INSIDE = Obstacles.vertical([[0.3, 0.0], [5.0, 5.0]], [0.5, 0.5])


@pytest.mark.parametrize("margin", [0.0, 0.05])
def test_h_is_negative_inside_and_clearance_is_the_signed_distance(margin):
    """Issue #14: EMERGENCY said 'inside' while h >= 0 (a robot leaving the circle)."""
    flt = SafetyFilter(HolonomicModel(), u_min=[-2, -2], u_max=[2, 2], margin=margin)
    for name, x, u_ref in _inside_cases():
        r = flt.filter(x, u_ref, INSIDE, yaw=0.0)
        assert r.status is FilterStatus.EMERGENCY, name
        assert r.h[0] < 0.0, (name, r.h)
        dist = np.hypot(*(INSIDE.center - x[:2]).T)
        np.testing.assert_allclose(r.clearance, dist - 0.5, atol=1e-12)
        assert r.active.tolist() == [True, False]
    # Outside: clearance = distance to the TRUE inflated circle [m], on every path.
    x = np.array([0.0, 0.0, 1.0, 0.0])
    for obs in (Obstacles.vertical([[1.2, 0.1]], [0.5]),  # one obstacle: closed form
                Obstacles.vertical([[1.2, 0.1], [1.4, -0.5]], [0.5, 0.3]),  # active set
                Obstacles.vertical([[0.52, 0.0]], [0.5])):  # within the margin band
        for method in ("auto", "qp"):
            f = SafetyFilter(HolonomicModel(), u_min=[-2, -2], u_max=[2, 2], margin=margin,
                             method=method)
            r = f.filter(x, [1.0, 0.0], obs, yaw=0.0)
            assert r.status is not FilterStatus.EMERGENCY
            np.testing.assert_allclose(
                r.clearance, np.hypot(*(obs.center - x[:2]).T) - obs.radius, atol=1e-12)


def test_clearance_is_reported_with_every_status(monkeypatch):
    model = HolonomicModel()
    x = np.array([0.0, 0.0, 3.0, 0.0])
    obs = Obstacles.vertical([[1.5, 0.0], [1.6, 0.5]], [0.5, 0.4])
    expected = np.hypot(*(obs.center - x[:2]).T) - obs.radius
    tight = SafetyFilter(model, u_min=[-0.1, -0.1], u_max=[0.1, 0.1])
    r = tight.filter(x, [1.0, 0.0], obs, yaw=0.0)
    assert r.status is FilterStatus.RELAXED
    np.testing.assert_allclose(r.clearance, expected, atol=1e-12)
    # the dense relaxed QP finds no optimum -> OSQP's relaxed QP, which fails -> FAILSAFE
    monkeypatch.setattr(DenseRelaxedQPs, "solve", lambda self, *a: None)
    monkeypatch.setattr(qp_mod.RelaxedQP, "solve", lambda self, *a: (np.zeros(2), 9))
    r = tight.filter(x, [1.0, 0.0], obs, yaw=0.0)
    assert r.status is FilterStatus.FAILSAFE and "non-convex" in r.message
    np.testing.assert_allclose(r.clearance, expected, atol=1e-12)


def test_a_robot_leaving_a_circle_is_not_braked():
    """Issue #14: inside and leaving, the escape action braked the outward motion."""
    flt = SafetyFilter(HolonomicModel(), u_min=[-2, -2], u_max=[2, 2])
    x = [0.0, 0.0, -0.5, 0.1]  # leaving the circle around (0.3, 0) at 0.49 m/s
    for u_ref in ([0.0, 0.0], [-1.0, 0.3], [0.2, 0.0]):
        r = flt.filter(x, u_ref, INSIDE, yaw=0.0)
        assert r.status is FilterStatus.EMERGENCY
        assert "leaving" in r.message and "not leaving" not in r.message
        np.testing.assert_array_equal(r.u_safe, u_ref)  # the reference, unchanged
    # A reference that would turn it back in is limited to "no deeper" (the exact QP).
    u_ref = np.array([2.0, -1.0])
    r = flt.filter(x, u_ref, INSIDE, yaw=0.0)
    p, v = np.array([0.3, 0.0]), -np.array(x[2:])
    e = p / np.linalg.norm(p)
    b = e @ v
    lf = (v @ v - b * b) / np.linalg.norm(p)
    t = c3bf_lie_derivatives(HolonomicModel(), x, INSIDE.center[1:], INSIDE.velocity[1:],
                             INSIDE.radius[1:] + flt.margin, INSIDE.plane[1:], yaw=0.0)
    G = np.vstack([-e, t.lg_h])
    rhs = np.r_[-(lf + flt.gamma * b), -(t.lf_h + flt.gamma * t.h)]
    u_ex = as_float(exact_qp(np.eye(2), u_ref, G, rhs, [-2, -2], [2, 2]))
    np.testing.assert_allclose(r.u_safe, u_ex, atol=1e-9)
    assert r.constraint[0] >= -1e-9 and r.u_safe[0] < u_ref[0]


def test_a_robot_not_leaving_brakes_and_backs_out():
    flt = SafetyFilter(HolonomicModel(), u_min=[-2, -2], u_max=[2, 2])
    for name, x, u_ref in _inside_cases()[1:]:
        r = flt.filter(x, u_ref, INSIDE, yaw=0.0)
        assert r.status is FilterStatus.EMERGENCY and "not leaving" in r.message, name
        away = np.array(x[:2]) - [0.3, 0.0]
        if np.linalg.norm(away) > 0:
            assert r.u_safe @ away > 0, name  # accelerates away from the centre


def test_exit_speed_keeps_a_slow_leaver_leaving():
    slow = [0.0, 0.0, -0.01, 0.0]  # leaving at 1 cm/s
    r0 = SafetyFilter(HolonomicModel()).filter(slow, [0.0, 0.0], INSIDE, yaw=0.0)
    np.testing.assert_array_equal(r0.u_safe, [0.0, 0.0])
    r1 = SafetyFilter(HolonomicModel(), exit_speed=0.2).filter(slow, [0.0, 0.0], INSIDE,
                                                               yaw=0.0)
    assert r1.status is FilterStatus.EMERGENCY and r1.u_safe[0] < -0.1  # pushed outwards


RADIAL_MODELS = [
    UnicycleModel(offset=0.0), UnicycleModel(offset=0.3), XZDoubleIntegratorModel(),
    HolonomicModel(), UnicycleHeightModel(offset=0.25), HolonomicHeightModel(),
    UnicycleLateralModel(offset=0.2), UnicycleLateralHeightModel(offset=0.25),
]


@pytest.mark.parametrize("model", RADIAL_MODELS, ids=repr)
def test_radial_speed_derivatives_match_finite_differences(model):
    """Lf b, Lg b of the no-deeper constraint (inside.py) against central differences of
    b = <p_rel, v_rel> / ||p_rel|| along f (with the obstacle's motion) and along g_j."""
    rng = np.random.default_rng(21)
    n = 400
    ranges = {"theta": (-np.pi, np.pi), "v": (-1.5, 2.0), "omega": (-2.0, 2.0),
              "z": (0.1, 0.6), "vz": (-1.0, 1.0), "vx": (-2.0, 2.0), "vy": (-2.0, 2.0)}
    lo = np.array([ranges.get(s, (-3, 3))[0] for s in model.state_names])
    hi = np.array([ranges.get(s, (-3, 3))[1] for s in model.state_names])
    X = rng.uniform(lo, hi, (n, model.n_x))
    yaw = rng.uniform(-np.pi, np.pi, n) if model.needs_yaw else None
    planes = sorted(int(p) for p in model.planes)
    plane = np.array(planes)[rng.integers(0, len(planes), n)]
    axes = PLANE_AXES[plane]
    kin = model.point_kinematics(X, yaw)
    P = np.take_along_axis(kin.position, axes, -1)
    ang = rng.uniform(-np.pi, np.pi, n)
    c = P + rng.uniform(0.05, 0.5, n)[:, None] * np.c_[np.cos(ang), np.sin(ang)]
    cv = rng.uniform(-1, 1, (n, 2)) * rng.integers(0, 2, (n, 1))

    def b_of(Xs, cs):
        k = model.point_kinematics(Xs, yaw)
        p = cs - np.take_along_axis(k.position, axes, -1)
        v = cv - np.take_along_axis(k.velocity, axes, -1)
        return (p * v).sum(-1) / np.linalg.norm(p, axis=-1)

    b0 = b_of(X, c)

    def fd(direction, rate, step=1e-5):
        def bb(k):
            return b_of(X + k * step * direction, c + k * step * rate)
        return (-bb(2) + 8 * bb(1) - 8 * bb(-1) + bb(-2)) / (12 * step)

    lf_fd = fd(model.f(X, yaw), cv)
    g = model.g(X, yaw)
    lg_fd = np.stack([fd(g[..., j], np.zeros_like(cv)) for j in range(model.n_u)], -1)
    for i in range(n):
        ki = model.point_kinematics(X[i], None if yaw is None else yaw[i])
        t = radial_terms(ki, c[i:i + 1], cv[i:i + 1], plane[i:i + 1])
        assert t.speed[0] == pytest.approx(b0[i], rel=1e-12, abs=1e-12)
        np.testing.assert_allclose(t.lf[0], lf_fd[i], rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(t.lg[0], lg_fd[i], rtol=1e-6, atol=1e-7)
