r"""The C3BF safety filter: a small QP over the robot's input.

For ``n`` obstacles with barrier terms ``h_i``, ``Lf h_i``, ``Lg h_i`` (see ``lie``) the filter
solves

.. math::

    \min_u\ (u - u_{ref})^T W (u - u_{ref})
    \quad\text{s.t.}\quad L_f h_i + L_g h_i\,u + \gamma h_i \ge 0\ (i = 1..n),
    \quad u_{min} \le u \le u_{max}.

Solution strategy (every path returns the exact optimum of that problem, or says otherwise):

1. ``u_ref`` satisfies every constraint and bound: returned unchanged, ``INACTIVE``.
2. One obstacle: closed form (the paper's KKT formula generalised to ``W``): for a violated
   constraint ``a u >= b`` the minimiser over that half-space alone is
   ``u* = u_ref + W^-1 a^T (b - a u_ref) / (a W^-1 a^T)``. The half-space contains the
   feasible set, so if ``u*`` is within the limits it is the optimum (``'closed_form'``).
3. Otherwise (several obstacles, or an active limit) the exact dual active-set method of
   Goldfarb and Idnani over the rows and the finite limits (``active_set.solve_box_qp``;
   ``'active_set'``). Its first step is the closed-form projection onto the most violated
   row; it ends with the optimum (KKT point of a strictly convex QP) or with a Farkas
   certificate of infeasibility (then step 5). Constraint rows are scaled to unit norm (same
   feasible set, better conditioning). The answer is verified (every row within 1e-9).
4. Fallback, and always with ``method='qp'``: OSQP (osqp 1.x). One solver object per problem
   size is set up once with a fixed sparsity pattern and then only updated (``q``, ``l``,
   ``u``, ``Ax``) and warm started. Rows that cannot bind inside the input box are
   disabled. The solution is polished and verified; if a row is still violated beyond 1e-9
   (scaled units) it is re-solved with tighter tolerances.
5. Infeasible (some constraint cannot hold within the limits: a Farkas certificate, or OSQP
   reports primal infeasibility): a relaxed QP with one non-negative slack ``d_i`` per constraint,
   ``a_i u + d_i >= b_i``, cost ``+ rho (sum d_i^2 + sum d_i)``: ``RELAXED``.
6. Body point inside an inflated circle (``||p_rel|| <= r``): ``EMERGENCY`` action,
   brake and accelerate away from the obstacle centre(s).
7. Solver failure or non-finite intermediate numbers: ``FAILSAFE`` brake input.

NaN/Inf or wrongly shaped inputs raise :class:`~.errors.InvalidInputError` before any work.
"""

from __future__ import annotations

import math
import time
from operator import ge, le, mul, or_
from typing import Literal, NamedTuple

import numpy as np
import osqp
import scipy.sparse as sp

from .active_set import solve_box_qp
from .barrier import DEFAULT_V_EPS
from .domain import MAX_MAGNITUDE, bad_entry
from .errors import InvalidInputError
from .geometry import Obstacles
from .lie import PLANE_AXES, BarrierTerms, barrier_terms, barrier_terms_scalar
from .models import PointKinematics, RobotModel
from .result import FilterResult, FilterStatus
from .solver_status import describe_osqp_status

__all__ = ["SafetyFilter", "cbf_closed_form"]

_OSQP_INF = 1e30
_EMERGENCY_REL_CLEARANCE = 1e-9  # ||p||^2 - r^2 <= 1e-9 r^2  =>  emergency
_ROW_ZERO = 1e-12  # ||Lg h|| below this: the constraint does not depend on u
_FEAS_TOL = 1e-9  # accepted violation of a unit-norm row [input units]
_ACTIVE_TOL = 1e-7  # scaled constraint value below which a row counts as binding
_SCALAR_TERMS_MAX = 16  # obstacles up to which barrier terms are computed per obstacle

_INFEASIBLE = (
    osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE,
    osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE_INACCURATE,
)
_RETRYABLE = (
    osqp.SolverStatus.OSQP_SOLVED,
    osqp.SolverStatus.OSQP_SOLVED_INACCURATE,
    osqp.SolverStatus.OSQP_MAX_ITER_REACHED,
)

_OSQP_DEFAULTS = {
    "verbose": False,
    "eps_abs": 1e-7,
    "eps_rel": 1e-7,
    "eps_prim_inf": 1e-7,
    "eps_dual_inf": 1e-7,
    "polishing": True,
    "polish_refine_iter": 5,
    "max_iter": 4000,
    "warm_starting": True,
    "check_termination": 10,
}


def cbf_closed_form(lg_h, lf_h, h, u_ref, gamma: float = 1.0, w_inv=None) -> np.ndarray:
    """Closed-form minimiser of ``(u-u_ref)^T W (u-u_ref)`` s.t. ``Lf h + Lg h u + gamma h >= 0``.

    The paper's KKT solution generalised to a weight ``W`` (input bounds are ignored)::

        psi = Lf h + Lg h u_ref + gamma h
        u   = u_ref                                     if psi >= 0
        u   = u_ref - W^-1 Lg h^T psi / (Lg h W^-1 Lg h^T)   otherwise

    Args:
        lg_h: ``(m,)`` ``Lg h``.
        lf_h: ``Lf h`` (scalar).
        h: Barrier value (scalar).
        u_ref: ``(m,)`` reference input.
        gamma: Class-K gain ``gamma`` [1/s].
        w_inv: ``(m, m)`` inverse weight ``W^-1`` (identity if None).

    Returns:
        ``(m,)`` safe input. If ``Lg h = 0`` the constraint cannot be influenced and ``u_ref``
        is returned.

    """
    a = np.asarray(lg_h, dtype=float)
    u0 = np.asarray(u_ref, dtype=float)
    psi = float(lf_h + a @ u0 + gamma * h)
    if psi >= 0.0:
        return u0.copy()
    wa = a if w_inv is None else np.asarray(w_inv, dtype=float) @ a
    den = float(a @ wa)
    if den <= 0.0:
        return u0.copy()
    return u0 - wa * (psi / den)


def _csc(data, indices, indptr, shape):
    """CSC matrix that keeps explicit entries (never drops zeros)."""
    return sp.csc_matrix(
        (np.asarray(data, float), np.asarray(indices, np.int64), np.asarray(indptr, np.int64)),
        shape=shape,
    )


class _HardQP:
    """``min 1/2 u'Wu + q'u`` s.t. ``l <= [G; I] u <= u`` with ``n`` rows of ``G``."""

    def __init__(self, n: int, m: int, w: np.ndarray, settings: dict):
        self.n, self.m = n, m
        # P: full upper triangle of W, column-major (CSC of triu).
        p_rows = [i for j in range(m) for i in range(j + 1)]
        p_ptr = np.r_[0, np.cumsum(np.arange(1, m + 1))]
        p_data = np.array([w[i, j] for j in range(m) for i in range(j + 1)])
        P = _csc(p_data, p_rows, p_ptr, (m, m))
        # A = [G; I]: column j holds rows 0..n-1 then row n+j.
        a_rows = np.concatenate([np.r_[np.arange(n), n + j] for j in range(m)])
        a_ptr = np.arange(m + 1) * (n + 1)
        self.ax = np.ones((m, n + 1))
        A = _csc(self.ax.ravel(), a_rows, a_ptr, (n + m, m))
        self.l = np.full(n + m, -_OSQP_INF)
        self.u = np.full(n + m, _OSQP_INF)
        self.solver = osqp.OSQP()
        self.solver.setup(P, np.zeros(m), A, self.l, self.u, **settings)
        self.settings = dict(settings)

    def solve(self, g_rows, lo, u_min, u_max, q):
        n = self.n
        self.ax[:, :n] = g_rows.T
        self.l[:n] = lo
        self.l[n:] = u_min
        self.u[n:] = u_max
        self.solver.update(q=q, l=self.l, u=self.u, Ax=self.ax.ravel())
        res = self.solver.solve(raise_error=False)
        return res.x[: self.m].copy(), int(res.info.status_val)

    def tighten(self, factor: float):
        s = self.settings
        self.solver.update_settings(
            eps_abs=s["eps_abs"] * factor, eps_rel=s["eps_rel"] * factor, max_iter=4 * s["max_iter"]
        )

    def restore(self):
        s = self.settings
        self.solver.update_settings(
            eps_abs=s["eps_abs"], eps_rel=s["eps_rel"], max_iter=s["max_iter"]
        )


class _RelaxedQP:
    """Variables ``(u, d)``; ``[G I; I 0; 0 I] (u, d)`` in ``[lo, inf; u_min, u_max; 0, inf]``."""

    def __init__(self, n: int, m: int, w: np.ndarray, rho: float, settings: dict):
        self.n, self.m = n, m
        p_rows = [i for j in range(m) for i in range(j + 1)] + list(range(m, m + n))
        p_ptr = np.r_[0, np.cumsum(np.arange(1, m + 1)), m * (m + 1) // 2 + np.arange(1, n + 1)]
        p_data = np.r_[[w[i, j] for j in range(m) for i in range(j + 1)], np.full(n, 2.0 * rho)]
        P = _csc(p_data, p_rows, p_ptr, (m + n, m + n))
        rows_u = [np.r_[np.arange(n), n + j] for j in range(m)]
        rows_d = [np.array([i, n + m + i]) for i in range(n)]
        a_rows = np.concatenate(rows_u + rows_d) if (rows_u or rows_d) else np.zeros(0)
        a_ptr = np.r_[np.arange(m + 1) * (n + 1), m * (n + 1) + 2 * np.arange(1, n + 1)]
        self.ax = np.ones(m * (n + 1) + 2 * n)
        self.ax_g = self.ax[: m * (n + 1)].reshape(m, n + 1)
        A = _csc(self.ax, a_rows, a_ptr, (2 * n + m, m + n))
        self.l = np.full(2 * n + m, -_OSQP_INF)
        self.l[n + m :] = 0.0
        self.u = np.full(2 * n + m, _OSQP_INF)
        self.q = np.full(m + n, rho)
        self.solver = osqp.OSQP()
        self.solver.setup(P, self.q.copy(), A, self.l, self.u, **settings)

    def solve(self, g_rows, lo, u_min, u_max, q_u):
        n, m = self.n, self.m
        self.ax_g[:, :n] = g_rows.T
        self.l[:n] = lo
        self.l[n : n + m] = u_min
        self.u[n : n + m] = u_max
        self.q[:m] = q_u
        self.solver.update(q=self.q, l=self.l, u=self.u, Ax=self.ax)
        res = self.solver.solve(raise_error=False)
        return res.x[:m].copy(), int(res.info.status_val)


def _vector(value, n: int, name: str, limit: float = math.inf):
    """``(array, list)`` of a ``(n,)`` input, entries finite with ``|x| <= limit``."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} is not a numeric array: {exc}") from exc
    if a.shape != (n,):
        raise InvalidInputError(f"{name} must have shape ({n},), got {a.shape}")
    lst = a.tolist()
    if not all(map(math.isfinite, lst)):
        raise InvalidInputError(f"{name} contains NaN or Inf: {lst}")
    if limit < math.inf and not math.hypot(*lst) <= limit:
        problem = bad_entry(name, a, limit)
        if problem:
            raise InvalidInputError(problem)
    return a, lst


class _Terms(NamedTuple):
    """The parts of :class:`~.lie.BarrierTerms` the QP needs (``(n,)``, ``lg_h`` ``(n, m)``)."""

    h: np.ndarray
    lf_h: np.ndarray
    lg_h: np.ndarray
    clearance: np.ndarray


class _Bounds(NamedTuple):
    lo: np.ndarray
    hi: np.ndarray
    lo_l: list
    hi_l: list
    finite: bool  # every limit finite


def _check_bounds(u_min, u_max, m: int) -> _Bounds:
    try:
        lo = np.full(m, -np.inf) if u_min is None else np.array(u_min, dtype=float)
        hi = np.full(m, np.inf) if u_max is None else np.array(u_max, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"u_min/u_max are not numeric: {exc}") from exc
    if lo.shape != (m,) or hi.shape != (m,):
        raise InvalidInputError(f"u_min/u_max must have shape ({m},) and no NaN")
    # Element-wise checks on Python floats (m is tiny): NaN, order, no +inf lower/-inf upper.
    lo_l, hi_l = lo.tolist(), hi.tolist()
    for a, b in zip(lo_l, hi_l, strict=True):
        if math.isnan(a) or math.isnan(b):
            raise InvalidInputError(f"u_min/u_max must have shape ({m},) and no NaN")
        if a > b or a == math.inf or b == -math.inf:
            raise InvalidInputError(f"need u_min <= u_max (finite or open), got {lo}, {hi}")
    return _Bounds(lo, hi, lo_l, hi_l, all(map(math.isfinite, lo_l + hi_l)))


class SafetyFilter:
    """Collision-cone CBF safety filter (C3BF-QP) for one robot model.

    Args:
        model: A :class:`~.models.RobotModel` (e.g. ``UnicycleHeightModel(offset=0.2)``).
        gamma: Class-K gain ``gamma`` [1/s] in ``Lf h + Lg h u + gamma h >= 0`` (> 0).
        weights: ``W``: None (identity), ``(m,)`` diagonal or ``(m, m)`` symmetric positive
            definite matrix.
        u_min: ``(m,)`` lower input limits (None: unbounded). SI units of the model's inputs.
        u_max: ``(m,)`` upper input limits (None: unbounded).
        v_eps: Relative-speed regularisation [m/s] of the barrier (see ``barrier``).
        margin: Extra radius [m] added to every obstacle for the constraints (see below).
        method: ``'auto'`` (closed form for one obstacle, the exact active-set method
            otherwise, OSQP as fallback) or ``'qp'`` (always OSQP once the reference is
            infeasible; for tests/benchmarks).
        relax_penalty: Penalty ``rho`` on slacks of the relaxed QP, relative to the largest
            eigenvalue of ``W``.
        brake_gain: Velocity damping gain [1/s] of the EMERGENCY and FAILSAFE inputs.
        escape_accel: Acceleration [m/s^2] away from the obstacle centre in EMERGENCY.
        osqp_settings: Overrides of the OSQP settings (see ``_OSQP_DEFAULTS``).

    Safety margin: the collision cone lets the body point graze the circle along a tangent
    (``h = 0`` there, distance exactly ``r``), so sampling, integration and tracking errors
    would touch or slightly enter it. The constraints therefore use ``r + margin``. If the
    body point is already inside ``r + margin`` but outside ``r``, that obstacle's constraint
    uses the exact barrier of the true ``r`` instead (still a valid C3BF, just less
    conservative); EMERGENCY is declared only inside ``r``. ``margin = 0`` gives the paper's
    filter exactly.

    The filter keeps OSQP solver objects between calls (one per obstacle count): use one
    instance per control loop, not concurrently from several threads.

    """

    def __init__(
        self,
        model: RobotModel,
        *,
        gamma: float = 1.0,
        weights=None,
        u_min=None,
        u_max=None,
        v_eps: float = DEFAULT_V_EPS,
        margin: float = 0.01,
        method: Literal["auto", "qp"] = "auto",
        relax_penalty: float = 1e2,
        brake_gain: float = 2.0,
        escape_accel: float = 1.0,
        osqp_settings: dict | None = None,
    ):
        if not isinstance(model, RobotModel):
            raise InvalidInputError("model must be a RobotModel")
        m = model.n_u
        self.model = model
        if not (np.isfinite(gamma) and gamma > 0):
            raise InvalidInputError("gamma must be finite and > 0")
        self.gamma = float(gamma)
        if weights is None:
            w = np.eye(m)
        else:
            w = np.asarray(weights, dtype=float)
            if w.shape == (m,):
                w = np.diag(w)
            if w.shape != (m, m) or not np.isfinite(w).all() or not np.allclose(w, w.T):
                raise InvalidInputError(f"weights must be (m,) or symmetric (m, m), m={m}")
            try:
                np.linalg.cholesky(w)
            except np.linalg.LinAlgError as exc:
                raise InvalidInputError("weights must be positive definite") from exc
        self.weights = w
        self._w_inv = np.linalg.inv(w)
        self._w_inv_l = self._w_inv.tolist()
        self._bounds = _check_bounds(u_min, u_max, m)
        self.u_min, self.u_max = self._bounds.lo, self._bounds.hi
        self._cur = self._bounds  # limits of the call in progress
        if not (np.isfinite(v_eps) and v_eps >= 0):
            raise InvalidInputError("v_eps must be finite and >= 0")
        self.v_eps = float(v_eps)
        if not (np.isfinite(margin) and margin >= 0):
            raise InvalidInputError("margin must be finite and >= 0")
        self.margin = float(margin)
        if method not in ("auto", "qp"):
            raise InvalidInputError("method must be 'auto' or 'qp'")
        self.method = method
        self._rho = float(relax_penalty) * float(np.linalg.eigvalsh(w).max())
        self.brake_gain = float(brake_gain)
        self.escape_accel = float(escape_accel)
        self._osqp_settings = {**_OSQP_DEFAULTS, **(osqp_settings or {})}
        # The relaxed QP is a fallback whose answer is a compromise anyway: looser tolerances
        # (still polished) keep its worst-case iteration count low.
        self._osqp_relaxed = {
            **self._osqp_settings,
            "eps_abs": max(self._osqp_settings["eps_abs"], 1e-5),
            "eps_rel": max(self._osqp_settings["eps_rel"], 1e-5),
        }
        self._hard: dict[int, _HardQP] = {}
        self._relaxed: dict[int, _RelaxedQP] = {}
        self._warm: tuple = (None, ())  # (row layout, active rows) of the last active-set solve

    # ------------------------------------------------------------------ public API
    def filter(
        self, state, u_ref, obstacles: Obstacles, yaw=None, *, u_min=None, u_max=None
    ) -> FilterResult:
        """Filter one reference input.

        Args:
            state: ``(n_x,)`` robot state in ``model.state_names`` order (SI, odom frame).
            u_ref: ``(n_u,)`` reference input in ``model.input_names`` order.
            obstacles: :class:`~.geometry.Obstacles` (inflated circles, constant velocity).
            yaw: Yaw [rad], required for models with ``needs_yaw`` (holonomic), else unused.
            u_min: ``(n_u,)`` lower input limits for this call only (e.g. derived from
                velocity limits); None: the constructor's ``u_min``. ``-inf`` allowed.
            u_max: ``(n_u,)`` upper input limits for this call only; None: constructor's.

        Returns:
            A :class:`~.result.FilterResult`; ``u_safe`` is always finite and within limits.

        Raises:
            InvalidInputError: NaN/Inf or wrongly shaped state, reference, yaw or obstacles,
                or an obstacle plane the model does not support.

        """
        t0 = time.perf_counter()
        model = self.model
        x, xl = _vector(state, model.n_x, "state", MAX_MAGNITUDE)
        u0, ul = _vector(u_ref, model.n_u, "u_ref")
        if model.needs_yaw:
            try:
                yaw = float(yaw)
            except (TypeError, ValueError) as exc:
                raise InvalidInputError(f"{type(model).__name__} needs yaw=<float>") from exc
            if not abs(yaw) <= MAX_MAGNITUDE:
                raise InvalidInputError(bad_entry("yaw", yaw))
        else:
            yaw = None
        if u_min is None and u_max is None:
            self._cur = self._bounds
        else:
            self._cur = self._call_bounds(u_min, u_max)
        if not isinstance(obstacles, Obstacles):
            raise InvalidInputError("obstacles must be an Obstacles instance")
        if not obstacles.planes_present <= model.planes:
            raise InvalidInputError(
                f"{type(model).__name__} supports only planes "
                f"{sorted(p.name for p in model.planes)}"
            )
        try:
            kin = model.point_kinematics_tuple(xl, yaw)
            if len(obstacles) == 1:
                res = self._filter_one(kin, u0, ul, obstacles, t0)
                if res is not None:
                    return res
            with np.errstate(all="ignore"):  # overflow etc. is detected and handled explicitly
                return self._filter(x, u0, ul, kin, obstacles, yaw, t0)
        except InvalidInputError:
            raise
        except Exception as exc:  # noqa: BLE001 - never raise on numerically hard cases
            return self._failsafe(x, yaw, len(obstacles), t0, f"internal error: {exc!r}")

    def _call_bounds(self, u_min, u_max) -> _Bounds:
        return _check_bounds(
            self.u_min if u_min is None else u_min,
            self.u_max if u_max is None else u_max,
            self.model.n_u,
        )

    def reset(self) -> None:
        """Drop the cached OSQP solvers and active set (warm starts restart from scratch)."""
        self._hard.clear()
        self._relaxed.clear()
        self._warm = (None, ())

    # ------------------------------------------------------------------ internals
    def _filter_one(self, kin, u0, ul, obs: Obstacles, t0) -> FilterResult | None:
        """Scalar fast path for one obstacle: INACTIVE or exact closed form, else None."""
        (c,), (cv,), (r,), (pl,) = obs.as_lists
        r += self.margin
        h, lf, lg, clearance = barrier_terms_scalar(
            kin, c[0], c[1], cv[0], cv[1], r, pl, self.v_eps
        )
        if not clearance > _EMERGENCY_REL_CLEARANCE * r * r:
            return None  # inside the margin band / emergency (or NaN): general path
        c0 = lf + self.gamma * h
        psi = c0 + sum(map(mul, lg, ul))
        if not math.isfinite(psi):
            return None  # overflow: the general path fails safe
        lo_b, hi_b = self._cur.lo_l, self._cur.hi_l
        in_box = all(map(le, lo_b, ul)) and all(map(le, ul, hi_b))
        if in_box and psi >= 0.0:
            status, u, ulist, solver = FilterStatus.INACTIVE, np.array(ul), ul, "none"
        elif self.method == "auto" and psi < 0.0:
            wa = [sum(map(mul, row, lg)) for row in self._w_inv_l]
            den = sum(map(mul, lg, wa))
            if not den > _ROW_ZERO**2 * (1.0 + abs(psi)):
                return None
            k = psi / den
            ulist = [v - k * w for v, w in zip(ul, wa, strict=True)]
            if not (all(map(le, lo_b, ulist)) and all(map(le, ulist, hi_b))):
                return None
            status, u, solver = FilterStatus.ACTIVE, np.array(ulist), "closed_form"
        else:
            return None
        con = c0 + sum(map(mul, lg, ulist))
        active = status is FilterStatus.ACTIVE and con * con <= _ACTIVE_TOL**2 * max(
            sum(map(mul, lg, lg)), 1.0
        )
        vals = np.array([h, con, 0.0 if con >= 0.0 else -con])
        flags = np.array([active, *map(or_, map(le, ulist, lo_b), map(ge, ulist, hi_b))])
        return FilterResult(
            u_safe=u,
            status=status,
            h=vals[0:1],
            constraint=vals[1:2],
            slack=vals[2:3],
            active=flags[0:1],
            bounds_active=flags[1:],
            solver=solver,
            solve_time=time.perf_counter() - t0,
        )

    def _terms(self, kin, obs: Obstacles, radius) -> _Terms:
        """h, Lf h, Lg h and clearance of every obstacle (``kin`` as tuples).

        Up to ``_SCALAR_TERMS_MAX`` obstacles the scalar formulas per obstacle
        (``barrier_terms_scalar``, tested against ``barrier_terms``) cost fewer operations
        than the vectorised ones; beyond that numpy is faster.
        """
        n = len(obs)
        if 0 < n <= _SCALAR_TERMS_MAX:
            v_eps, fn = self.v_eps, barrier_terms_scalar
            rows = [
                fn(kin, c[0], c[1], v[0], v[1], r, pl, v_eps)
                for c, v, r, pl in zip(
                    obs.center.tolist(), obs.velocity.tolist(), radius.tolist(),
                    obs.plane.tolist(), strict=True,
                )
            ]
            h, lf, lg, clearance = zip(*rows, strict=True)
            return _Terms(np.array(h), np.array(lf), np.array(lg), np.array(clearance))
        kin = PointKinematics(*(np.array(k, dtype=float) for k in kin))
        t = barrier_terms(kin, obs.center, obs.velocity, radius, obs.plane, self.v_eps)
        return _Terms(t.h, t.lf_h, t.lg_h.reshape(n, self.model.n_u), t.clearance)

    def _filter(self, x, u0, ul, kin, obs: Obstacles, yaw, t0) -> FilterResult:
        radius = obs.radius + self.margin
        terms = self._terms(kin, obs, radius)
        inside = terms.clearance <= _EMERGENCY_REL_CLEARANCE * radius * radius
        if self.margin > 0.0 and inside.any():
            # Inside r + margin: use the exact barrier of the true radius r for those rows.
            radius = np.where(inside, obs.radius, radius)
            terms = self._terms(kin, obs, radius)
            inside = terms.clearance <= _EMERGENCY_REL_CLEARANCE * radius * radius
        G = terms.lg_h
        c0 = terms.lf_h + self.gamma * terms.h  # constraint: G u + c0 >= 0
        if not (np.isfinite(c0).all() and np.isfinite(G).all()):
            return self._failsafe(x, yaw, len(obs), t0, "non-finite barrier terms")
        if inside.any():
            kin = PointKinematics(*(np.array(k, dtype=float) for k in kin))
            full = barrier_terms(kin, obs.center, obs.velocity, radius, obs.plane, self.v_eps)
            return self._emergency(x, yaw, kin, full, obs.plane, inside, c0, t0)
        cur = self._cur
        lo_b, hi_b = cur.lo, cur.hi
        in_box = all(map(le, cur.lo_l, ul)) and all(map(le, ul, cur.hi_l))
        if in_box and (G @ u0 + c0 >= 0.0).all():
            return self._result(u0.copy(), FilterStatus.INACTIVE, terms, G, c0, "none", t0)

        norms = np.sqrt(np.einsum("ij,ij->i", G, G))
        dead = norms <= _ROW_ZERO  # rows that u cannot influence
        any_dead = bool(dead.any())
        if any_dead:
            scale = np.where(dead, 1.0, norms)
            Gn = G / scale[:, None]
            bn = -c0 / scale  # scaled constraint: Gn u >= bn
        else:
            Gn = G / norms[:, None]
            bn = -c0 / norms
        hopeless = any_dead and bool((dead & (c0 < 0.0)).any())

        if self.method == "auto" and not hopeless:
            # Exact dual active-set solve (its first step is the closed-form projection).
            live = ~dead if any_dead else slice(None)
            # Warm start from the last call's active rows when the row layout is the same.
            layout = (len(obs), cur.finite) if not any_dead else None
            warm = self._warm[1] if layout is not None and self._warm[0] == layout else ()
            sol = solve_box_qp(
                self._w_inv, u0, Gn[live], bn[live], lo_b, hi_b, cur.finite, warm
            )
            self._warm = (layout, sol.active)
            if sol.u is not None:
                u = np.minimum(np.maximum(sol.u, lo_b), hi_b)  # np.clip, less overhead
                if self._verify(u, Gn, np.where(dead, -_OSQP_INF, bn) if any_dead else bn):
                    return self._result(
                        u, FilterStatus.ACTIVE, terms, G, c0, "active_set", t0, norms=norms
                    )
            infeasible = sol.infeasible  # a Farkas certificate: go straight to the relaxed QP
        else:
            infeasible = False

        # OSQP. Which rows can bind inside the box, which cannot hold at all?
        with np.errstate(invalid="ignore"):
            row_min = np.where(Gn > 0, Gn * lo_b, np.where(Gn < 0, Gn * hi_b, 0.0)).sum(axis=1)
            row_max = np.where(Gn > 0, Gn * hi_b, np.where(Gn < 0, Gn * lo_b, 0.0)).sum(axis=1)
        redundant = dead | (bn <= row_min)
        lo_rows = np.where(redundant, -_OSQP_INF, bn)
        infeasible = (
            infeasible or hopeless or bool((bn > row_max + _FEAS_TOL)[~redundant].any())
        )
        q = -(self.weights @ u0)
        n = len(obs)
        msg = "constraints infeasible within input limits"
        if not infeasible:
            u, ok, status_val = self._solve_hard(n, Gn, lo_rows, q)
            if ok:
                msg = "" if status_val == osqp.SolverStatus.OSQP_SOLVED else (
                    f"hard QP {describe_osqp_status(status_val)}: feasible, "
                    "optimality not certified"
                )
                return self._result(u, FilterStatus.ACTIVE, terms, G, c0, "osqp", t0, msg)
            if status_val not in _INFEASIBLE:
                if status_val not in _RETRYABLE:
                    return self._failsafe(
                        x, yaw, n, t0, f"hard QP failed: {describe_osqp_status(status_val)}",
                        terms, G, c0,
                    )
                msg = (
                    f"hard QP not solved to tolerance ({describe_osqp_status(status_val)}): "
                    "relaxed QP used"
                )
        u, status_val = self._solve_relaxed(n, Gn, lo_rows, q)
        if u is None:
            return self._failsafe(
                x, yaw, n, t0, f"relaxed QP failed: {describe_osqp_status(status_val)}",
                terms, G, c0,
            )
        return self._result(u, FilterStatus.RELAXED, terms, G, c0, "osqp", t0, msg)

    def _verify(self, u, Gn, lo_rows) -> bool:
        return bool(np.isfinite(u).all() and (Gn @ u >= lo_rows - _FEAS_TOL).all())

    def _solve_hard(self, n, Gn, lo_rows, q):
        qp = self._hard.get(n)
        if qp is None:
            qp = self._hard[n] = _HardQP(n, self.model.n_u, self.weights, self._osqp_settings)
        u, st = qp.solve(Gn, lo_rows, self._cur.lo, self._cur.hi, q)
        solved = (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)
        if st in solved or st == osqp.SolverStatus.OSQP_MAX_ITER_REACHED:
            u = np.clip(u, self._cur.lo, self._cur.hi)
            if self._verify(u, Gn, lo_rows):
                return u, True, st
            # Tighten and re-solve (warm started from the previous iterate).
            qp.tighten(1e-3)
            try:
                u2, st = qp.solve(Gn, lo_rows, self._cur.lo, self._cur.hi, q)
            finally:
                qp.restore()
            u2 = np.clip(u2, self._cur.lo, self._cur.hi)
            if st in solved and self._verify(u2, Gn, lo_rows):
                return u2, True, st
        return None, False, st

    def _solve_relaxed(self, n, Gn, lo_rows, q):
        qp = self._relaxed.get(n)
        if qp is None:
            qp = self._relaxed[n] = _RelaxedQP(
                n, self.model.n_u, self.weights, self._rho, self._osqp_relaxed
            )
        u, st = qp.solve(Gn, lo_rows, self._cur.lo, self._cur.hi, q)
        ok = (
            osqp.SolverStatus.OSQP_SOLVED,
            osqp.SolverStatus.OSQP_SOLVED_INACCURATE,
            osqp.SolverStatus.OSQP_MAX_ITER_REACHED,
        )
        if st not in ok or not np.isfinite(u).all():
            return None, st
        return np.clip(u, self._cur.lo, self._cur.hi), st

    def _result(
        self, u, status, terms: _Terms, G, c0, solver, t0, message="", norms=None
    ):
        if not np.isfinite(u).all():
            raise FloatingPointError("non-finite filtered input")  # -> FAILSAFE
        con = c0 + G @ u
        if status is FilterStatus.INACTIVE:
            active = np.zeros(con.shape, dtype=bool)
        else:
            if norms is None:
                norms = np.sqrt(np.einsum("ij,ij->i", G, G))
            active = con <= _ACTIVE_TOL * np.maximum(norms, 1.0)
        bounds = (u <= self._cur.lo) | (u >= self._cur.hi)
        return FilterResult(
            u_safe=u,
            status=status,
            h=terms.h,
            constraint=con,
            slack=np.maximum(-con, 0.0),
            active=active,
            bounds_active=bounds,
            solver=solver,
            solve_time=time.perf_counter() - t0,
            message=message,
        )

    def _brake(self, x, yaw) -> np.ndarray:
        u = np.asarray(self.model.brake_input(x, yaw, self.brake_gain), dtype=float)
        u = np.where(np.isfinite(u), u, 0.0)
        return np.clip(u, self._cur.lo, self._cur.hi)

    def _failsafe(self, x, yaw, n, t0, message, terms=None, G=None, c0=None) -> FilterResult:
        u = self._brake(x, yaw)
        u = np.where(np.isfinite(u), u, np.clip(0.0, self._cur.lo, self._cur.hi))
        if terms is None or G is None or c0 is None:
            h = con = np.zeros(n)
        else:
            h = np.nan_to_num(terms.h)
            con = np.nan_to_num(c0 + G @ u)
        return FilterResult(
            u_safe=u,
            status=FilterStatus.FAILSAFE,
            h=h,
            constraint=con,
            slack=np.maximum(-con, 0.0),
            active=np.zeros(n, dtype=bool),
            bounds_active=(u <= self._cur.lo) | (u >= self._cur.hi),
            solver="none",
            solve_time=time.perf_counter() - t0,
            message=message,
        )

    def _emergency(self, x, yaw, kin, terms: BarrierTerms, plane, inside, c0, t0) -> FilterResult:
        """Brake and accelerate the body point away from the centres it is inside."""
        G = terms.lg_h
        plane_axes = PLANE_AXES[plane[inside]]
        away_2d = -terms.p_rel[inside]  # body point minus obstacle centre, in-plane
        dist = np.linalg.norm(away_2d, axis=1)
        v3 = kin.velocity
        for i in np.flatnonzero(dist < 1e-9):  # exactly at the centre: back off along -V
            back = -v3[plane_axes[i]]
            nb = np.linalg.norm(back)
            away_2d[i] = back / nb if nb > 1e-9 else np.array([-1.0, 0.0])
            dist[i] = 1.0
        away = np.zeros(3)
        np.add.at(away, plane_axes, away_2d / dist[:, None])
        na = np.linalg.norm(away)
        if na > 1e-12:
            away /= na
        a_des = -self.brake_gain * v3 + self.escape_accel * away
        B = kin.accel_input
        B_pinv = np.linalg.pinv(B)
        u = B_pinv @ (a_des - kin.accel_drift)
        null = np.eye(B.shape[1]) - B_pinv @ B
        u = u + null @ np.asarray(self.model.brake_input(x, yaw, self.brake_gain), dtype=float)
        if not np.isfinite(u).all():
            u = self._brake(x, yaw)
        u = np.clip(u, self._cur.lo, self._cur.hi)
        con = np.nan_to_num(c0 + G @ u)
        return FilterResult(
            u_safe=u,
            status=FilterStatus.EMERGENCY,
            h=np.nan_to_num(terms.h),
            constraint=con,
            slack=np.maximum(-con, 0.0),
            active=inside.copy(),
            bounds_active=(u <= self._cur.lo) | (u >= self._cur.hi),
            solver="none",
            solve_time=time.perf_counter() - t0,
            message=f"inside the inflated radius of obstacle(s) {np.flatnonzero(inside).tolist()}",
        )
