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
3. Otherwise (several obstacles, or an active limit) an exact dual active-set method over
   the rows and the limits: DAQP, compiled, one workspace per row count warm started from the
   last call's working set (``dense_qp``; ``'active_set'``). It ends with the optimum (KKT
   point of a strictly convex QP) or with a certificate of infeasibility (then step 5).
   Constraint rows are scaled to unit norm (same feasible set, better conditioning). The
   answer is verified (every row within 1e-9). On the fast path the last optimum's working
   set is re-solved first (``working_set``, at most ``m`` constraints on floats) and taken
   when it is a KKT point within DAQP's own tolerance: DAQP's answer without the call.
4. Fallback, and always with ``method='qp'``: OSQP (osqp 1.x). One solver object per problem
   size is set up once with a fixed sparsity pattern and then only updated (``q``, ``l``,
   ``u``, ``Ax``) and warm started. Rows that cannot bind inside the input box are
   disabled. The solution is polished and verified; if a row is still violated beyond 1e-9
   (scaled units) it is re-solved with tighter tolerances.
   If OSQP stops without converging (e.g. a thin feasible slab) the exact active-set method
   answers before anything is relaxed. OSQP answers are accurate to its tolerances, which
   are relative to ``|q| = |W u_ref|``; the closed form and active-set answers to rounding.
5. Infeasible (some constraint cannot hold within the limits: a Farkas certificate, or OSQP
   reports primal infeasibility): a relaxed QP with one non-negative slack ``d_i`` per constraint,
   ``a_i u + d_i >= b_i``, cost ``+ rho (sum d_i^2 + sum d_i)``: ``RELAXED``. With
   ``method='auto'`` DAQP solves it exactly (``dense_relaxed_qp``; ``'active_set'``), OSQP if
   DAQP finds no optimum; with ``method='qp'`` OSQP.
6. Body point inside an inflated circle (``||p_rel||^2 - r^2 < 1e-9 r^2``): ``EMERGENCY``.
   Leaving every such circle: steps 1-5 with their cone rows replaced by the no-deeper rows
   of the radial speed (``inside``); otherwise brake and accelerate away from the centres.
7. Solver failure or non-finite intermediate numbers: ``FAILSAFE`` brake input.

Whole body (``body=`` a :class:`~.body.RobotBody`): one row per (body point, obstacle) pair
of the same plane, each with its point's own kinematics and the obstacle grown by the
point's radius (``body_rows``); steps 1 and 3-7 as above on those rows, and the result
folded back to one entry per obstacle (its worst row). ``body=None`` is the paper's
single body point of the model.

Inputs outside the numeric domain (NaN/Inf, ``|x| > 1e9``, wrong shapes; see ``domain``)
raise :class:`~.errors.InvalidInputError` naming the entry, before any work. A reference
beyond ``domain.REF_RATIO_MAX`` x the input scale is answered only where the answer is exact
(its clip), else refused the same way.

Every row comes from one vectorised formula (``lie.cone_rows``). The usual call of the
single-point filter (every row clear of its circle and of low relative speeds, ``method =
'auto'``) takes ``fast_path``: the rows in a few array operations on the obstacle set's
layout (``rows.PointRows``, kept while the same :class:`~.geometry.Obstacles` object comes
back: an ``Obstacles`` is immutable, so nothing is validated or laid out again), then steps
1-5 as above on them. Everything else takes the general path here, with the same formula's
clamp and low-speed blend; both give the same answers.

This module holds the policy (which step answers, statuses, messages); the parts live in
``filter_inputs`` (validation), ``rows`` (barrier terms, unit-norm rows), ``fast_path`` (the
usual call), ``closed_form`` (step 2), ``dense_qp`` (step 3), ``osqp_qp`` (steps 4-5),
``inside`` (step 6) and ``filter_outputs`` (the :class:`~.result.FilterResult`).
"""

from __future__ import annotations

import math
import time
from operator import le
from typing import Literal

import numpy as np
import osqp

from .barrier import DEFAULT_V_EPS
from .body import RobotBody
from .body_rows import body_rows, per_obstacle
from .closed_form import cbf_closed_form
from .dense_qp import DAQP_INF, DenseQPs
from .dense_relaxed_qp import DenseRelaxedQPs
from .domain import REF_RATIO_MAX, checked_scalar, far_reference_error
from .errors import InvalidInputError
from .fast_path import fast_filter, one_row
from .filter_inputs import FLOAT_MAX, Bounds, check_bounds, check_weights, check_yaw, vector
from .filter_outputs import failsafe_result, make_result
from .geometry import Obstacles
from .inside import INSIDE_REL_CLEARANCE, escape_input, inside_rows, rows_of
from .lie import reference_directions
from .models import PointKinematics, RobotModel
from .osqp_qp import INFEASIBLE, RETRYABLE, QPSolvers
from .result import FilterResult, FilterStatus
from .rows import (
    FEAS_TOL,
    ROUND_TOL,
    PointRows,
    Rows,
    Terms,
    obstacle_terms,
    scale_rows,
    screen_rows,
)
from .solver_status import describe_osqp_status

__all__ = ["DEFAULT_MARGIN", "DIRECTION_HORIZON", "SafetyFilter", "cbf_closed_form"]

DEFAULT_MARGIN = 0.01
"""The filter's own extra radius [m] on every obstacle (``SafetyFilter(margin=...)``)."""

DIRECTION_HORIZON = 0.2
"""Time [s] ahead at which the whole-body filter takes the reference's relative-velocity
direction for its rows below ``v_eps`` (``lie.row_barrier_terms``)."""

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
        exit_speed: Radial speed [m/s] a robot inside a circle and leaving it is kept at
            (at least, asymptotically): 0 only forbids going deeper (see ``inside``).
        osqp_settings: Overrides of the OSQP settings (see ``OSQP_DEFAULTS``).
        body: A :class:`~.body.RobotBody` for the whole-body filter (its points' offsets
            replace the model's body point; the model's ``offset`` is not used), or None for
            the paper's single body point.

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
        margin: float = DEFAULT_MARGIN,
        method: Literal["auto", "qp"] = "auto",
        relax_penalty: float = 1e2,
        brake_gain: float = 2.0,
        escape_accel: float = 1.0,
        exit_speed: float = 0.0,
        osqp_settings: dict | None = None,
        body: RobotBody | None = None,
    ):
        if not isinstance(model, RobotModel):
            raise InvalidInputError("model must be a RobotModel")
        m = model.n_u
        self.model = model
        self.gamma = checked_scalar("gamma", gamma, 0.0, low_open=True)
        w = check_weights(weights, m)
        self.weights = w
        self._w_diag = bool((w == np.diag(np.diag(w))).all())  # W-projection on a box = clip
        self._w_inv = np.linalg.inv(w)
        self._w_inv_l = self._w_inv.tolist()
        self._w_inv_ws = None if (w == np.eye(m)).all() else self._w_inv_l  # (``working_set``)
        self._bounds = check_bounds(u_min, u_max, m)
        self.u_min, self.u_max = self._bounds.lo, self._bounds.hi
        self._cur = self._bounds  # limits of the call in progress
        self._far = False  # the call in progress has a far reference (domain.REF_RATIO_MAX)
        self._umax = 0.0  # ||u_ref|| of the call in progress
        self.v_eps = checked_scalar("v_eps", v_eps, 0.0)
        self.margin = checked_scalar("margin", margin, 0.0)
        if method not in ("auto", "qp"):
            raise InvalidInputError("method must be 'auto' or 'qp'")
        self.method = method
        relax_penalty = checked_scalar("relax_penalty", relax_penalty, 0.0, low_open=True)
        self.brake_gain = checked_scalar("brake_gain", brake_gain, 0.0)
        self.escape_accel = checked_scalar("escape_accel", escape_accel, 0.0)
        self.exit_speed = checked_scalar("exit_speed", exit_speed, 0.0)
        self._qp = QPSolvers(w, relax_penalty, osqp_settings)
        self._dense = DenseQPs(w)  # DAQP workspaces (warm started), one per row count
        self._dense_relaxed = DenseRelaxedQPs(w, self._qp.rho)  # step 5 on DAQP
        if body is not None and not isinstance(body, RobotBody):
            raise InvalidInputError("body must be a RobotBody or None")
        self.body = body
        self._point: PointRows | None = None  # the last obstacle set's layout (``rows``)

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
            InvalidInputError: NaN/Inf, out-of-domain (``|x| > 1e9``) or wrongly shaped
                state, reference, yaw, limits or obstacles; an obstacle plane the model does
                not support; a reference beyond ``domain.REF_RATIO_MAX`` x the input scale
                whose clip to the limits is not the exact optimum.

        """
        t0 = time.perf_counter()
        model = self.model
        x, xl, _ = vector(state, model.n_x, "state")
        u0, ul, umax = vector(u_ref, model.n_u, "u_ref", FLOAT_MAX)
        yaw = check_yaw(model, yaw)
        if u_min is None and u_max is None:
            self._cur = self._bounds
        else:
            self._cur = self._call_bounds(u_min, u_max)
        # Far reference (see domain.REF_RATIO_MAX): only exact answers, else InvalidInputError.
        self._far = far = umax > REF_RATIO_MAX and max(map(abs, ul)) > (
            REF_RATIO_MAX * self._cur.scale
        )
        self._umax = umax
        if not isinstance(obstacles, Obstacles):
            raise InvalidInputError("obstacles must be an Obstacles instance")
        if not obstacles.planes_present <= model.planes:
            raise InvalidInputError(
                f"{type(model).__name__} supports only planes "
                f"{sorted(p.name for p in model.planes)}"
            )
        try:
            if self.body is not None:
                return self._filter_body(x, u0, ul, obstacles, yaw, t0)
            kin = model.point_kinematics_tuple(xl, yaw)
            if not far and self.method == "auto" and len(obstacles):
                res = fast_filter(self, x, yaw, kin, u0, ul, obstacles, t0)
                if res is not None:
                    return res
            with np.errstate(all="ignore"):  # overflow etc. is detected and handled explicitly
                return self._filter(x, u0, ul, kin, obstacles, yaw, t0)
        except InvalidInputError:
            raise
        except Exception as exc:  # noqa: BLE001 - never raise on numerically hard cases
            return self._failsafe(x, yaw, len(obstacles), t0, f"internal error: {exc!r}")

    def _call_bounds(self, u_min, u_max) -> Bounds:
        return check_bounds(
            self.u_min if u_min is None else u_min,
            self.u_max if u_max is None else u_max,
            self.model.n_u,
        )

    def reset(self) -> None:
        """Drop the cached OSQP and DAQP solvers (warm starts restart from scratch)."""
        self._qp.clear()
        self._dense.clear()
        self._dense_relaxed.clear()
        self._point = None

    def _point_rows(self, obs: Obstacles) -> PointRows:
        """The :class:`~.rows.PointRows` of ``obs``: kept while the same object comes back.

        An :class:`~.geometry.Obstacles` is immutable (read-only arrays, validated once), so
        the same object is the same set; any other object, even with equal numbers, gets a
        new layout. The reference held here keeps ``obs`` alive (its identity unique).
        """
        point = self._point
        if point is None or point.obs is not obs:
            point = self._point = PointRows(obs, self.margin, self.v_eps, self.model.n_u)
        return point

    # ------------------------------------------------------------------ internals
    def _filter_body(self, x, u0, ul, obs: Obstacles, yaw, t0) -> FilterResult:
        """The whole-body filter: rows per (body point, obstacle), folded per obstacle."""
        if len(obs) == 0:
            kin = self.model.point_kinematics_tuple(x.tolist(), yaw)
            return self._filter(x, u0, ul, kin, obs, yaw, t0)
        rows = body_rows(self.model, x, yaw, self.body, obs)
        with np.errstate(all="ignore"):  # overflow etc. is detected and handled explicitly
            res = self._filter(x, u0, ul, rows.kin, rows.obstacles, yaw, t0, rows.obstacle)
        return per_obstacle(res, rows, len(obs))

    def _filter(self, x, u0, ul, kin, obs: Obstacles, yaw, t0, row_obstacle=None):
        """Barrier terms of every obstacle, then the QP (or the inside-a-circle handling).

        ``row_obstacle``: whole body, the obstacle of each row (``body_rows``); None for the
        single body point.
        """
        radius = obs.radius + self.margin
        e = None
        if row_obstacle is not None:  # whole body: the reference's directions at rest
            e = reference_directions(kin, obs.center, obs.velocity, obs.plane, u0,
                                     DIRECTION_HORIZON)
        point = None if row_obstacle is not None else self._point_rows(obs)
        terms = obstacle_terms(kin, obs, radius, self.v_eps, self.gamma, e, point)
        inside = terms.clearance < INSIDE_REL_CLEARANCE * radius * radius
        band = self.margin > 0.0 and bool(inside.any())
        if band:
            # Inside r + margin: use the exact barrier of the true radius r for those rows.
            radius = np.where(inside, obs.radius, radius)
            terms = obstacle_terms(kin, obs, radius, self.v_eps, self.gamma, e, point)
            inside = terms.clearance < INSIDE_REL_CLEARANCE * radius * radius
        G, c0 = terms.G, terms.c0  # constraint: G u + c0 >= 0
        if not (np.isfinite(c0).all() and np.isfinite(G).all()):
            return self._failsafe(x, yaw, len(obs), t0, "non-finite barrier terms")
        if inside.any():
            return self._inside(x, u0, ul, yaw, kin, obs, radius, terms, inside, t0,
                                row_obstacle)
        if point is not None and len(c0) == 1 and not band and self.method == "auto" and not (
                self._far):  # one row: INACTIVE or the closed form, as on the fast path
            row = (terms.h[0], c0[0], G[0].tolist(), terms.clearance[0], terms.gap[0])
            res = one_row(self, row, u0, ul, t0)
            if res is not None:
                return res
        return self._solve(x, u0, ul, yaw, terms, G, c0, t0)

    def _solve(self, x, u0, ul, yaw, terms: Terms, G, c0, t0) -> FilterResult:
        """The QP for the rows ``G u + c0 >= 0`` (module docstring, steps 1-5)."""
        cur = self._cur
        in_box = all(map(le, cur.lo_l, ul)) and all(map(le, ul, cur.hi_l))
        if in_box and (G @ u0 + c0 >= 0.0).all():
            return make_result(u0.copy(), FilterStatus.INACTIVE, terms, G, c0, cur, "none", t0)
        if self._far:
            return self._far_reference(u0, terms, G, c0, t0)
        rows = scale_rows(G, c0)
        infeasible = rows.hopeless
        if not infeasible and self.method == "auto":
            u, infeasible = self._active_set(u0, rows)
            if u is not None:
                return make_result(
                    u, FilterStatus.ACTIVE, terms, G, c0, cur, "active_set", t0, norms=rows.norms
                )
        return self._solve_osqp(x, u0, yaw, terms, rows, infeasible, t0)

    def _active_set(self, u0, rows: Rows):
        """Exact dual active-set solve (DAQP): ``(u or None, infeasible)``; ``u`` verified.

        Rows ``u`` cannot influence (``rows.dead``) are switched off. The workspace for this
        row count starts from its last working set (``dense_qp``).
        """
        cur = self._cur
        lo_rows = np.where(rows.dead, -DAQP_INF, rows.bn) if rows.any_dead else rows.bn
        sol = self._dense.solve(u0, rows.Gn, lo_rows, cur.lo, cur.hi)
        if sol.u is not None:
            u = np.minimum(np.maximum(sol.u, cur.lo), cur.hi)  # np.clip, less overhead
            if self._verify(u, rows.Gn, lo_rows):
                return u, False
        return None, sol.infeasible  # infeasible: DAQP's certificate (confirmed cold)

    def _solve_osqp(self, x, u0, yaw, terms: Terms, rows: Rows, infeasible, t0):
        """OSQP on the rows that can bind inside the box; the relaxed QP if infeasible."""
        cur = self._cur
        lo_b, hi_b = cur.lo, cur.hi
        Gn, G, c0 = rows.Gn, rows.G, rows.c0
        lo_rows, infeasible = screen_rows(rows, lo_b, hi_b, infeasible)
        q = -(self.weights @ u0)
        n = len(rows.bn)
        msg = "constraints infeasible within input limits"
        if not infeasible:
            u, ok, st = self._qp.solve_hard(n, Gn, lo_rows, lo_b, hi_b, q, self._verify)
            if ok:
                msg = "" if st == osqp.SolverStatus.OSQP_SOLVED else (
                    f"hard QP {describe_osqp_status(st)}: feasible, optimality not certified"
                )
                return make_result(u, FilterStatus.ACTIVE, terms, G, c0, cur, "osqp", t0, msg)
            if st not in INFEASIBLE:
                words = describe_osqp_status(st)
                if st not in RETRYABLE:
                    return self._failsafe(x, yaw, n, t0, f"hard QP failed: {words}", terms, G, c0)
                if self.method == "qp" and not rows.hopeless:
                    # OSQP did not converge (e.g. a thin feasible slab): the exact method has
                    # not run yet, let it answer before relaxing anything.
                    u, infeasible = self._active_set(u0, rows)
                    if u is not None:
                        msg = f"hard QP {words}: answered by the exact active-set method"
                        return make_result(
                            u, FilterStatus.ACTIVE, terms, G, c0, cur, "active_set", t0, msg
                        )
                if not infeasible:
                    msg = f"hard QP not solved to tolerance ({words}): relaxed QP used"
        if self.method == "auto":  # the exact dense solve; OSQP if it finds no optimum
            u = self._dense_relaxed.solve(u0, Gn, lo_rows, lo_b, hi_b)
            if u is not None:
                return make_result(u, FilterStatus.RELAXED, terms, G, c0, cur, "active_set", t0,
                                   msg)
        u, st = self._qp.solve_relaxed(n, Gn, lo_rows, lo_b, hi_b, q)
        if u is None:
            return self._failsafe(
                x, yaw, n, t0, f"relaxed QP failed: {describe_osqp_status(st)}", terms, G, c0
            )
        return make_result(u, FilterStatus.RELAXED, terms, G, c0, cur, "osqp", t0, msg)

    def _inside(self, x, u0, ul, yaw, kin, obs: Obstacles, radius, terms: Terms, inside, t0,
                row_obstacle=None):
        """Body point inside >= 1 inflated circle: EMERGENCY (see ``inside``).

        Leaving every such circle: the QP with their radial no-deeper rows in place of their
        cone rows. Otherwise: brake and back out of them (the escape input).
        """
        kin = PointKinematics(*(np.array(k, dtype=float) for k in kin))
        idx, rad, terms, G, c0 = inside_rows(
            kin, obs, radius, terms, inside, self.gamma, self.exit_speed
        )
        names = idx.tolist() if row_obstacle is None else sorted(
            set(row_obstacle[idx].tolist()))  # obstacles, not (point, obstacle) rows
        if (rad.speed > 0.0).all():
            res = self._solve(x, u0, ul, yaw, terms, G, c0, t0)
            if res.status is not FilterStatus.FAILSAFE:
                speeds = ", ".join(f"{s:.3g}" for s in rad.speed.tolist())
                res.message = (
                    f"inside the inflated radius of obstacle(s) {names} and leaving (radial "
                    f"speed {speeds} m/s): the reference is kept unless it would go deeper"
                    + (f"; {res.message}" if res.message else "")
                )
                res.status, res.active = FilterStatus.EMERGENCY, inside.copy()
                return res
        brake_u = self.model.brake_input(x, yaw, self.brake_gain)
        deepest = idx[int(np.argmin(terms.clearance[idx]))]  # its point escapes (whole body)
        u = escape_input(
            rows_of(kin, deepest), rad.p_rel, obs.plane[idx], brake_u, self.brake_gain,
            self.escape_accel,
        )
        if not np.isfinite(u).all():
            u = self._brake(x, yaw)
        u = np.clip(u, self._cur.lo, self._cur.hi)
        msg = f"inside the inflated radius of obstacle(s) {names}, not leaving: brake, back out"
        res = make_result(u, FilterStatus.EMERGENCY, terms, G, c0, self._cur, "none", t0, msg)
        res.active = inside.copy()
        return res

    def _far_reference(self, u0, terms: Terms, G, c0, t0) -> FilterResult:
        """Far ``u_ref`` (beyond ``REF_RATIO_MAX`` x the input scale), not itself admissible.

        Its clip when that is the exact optimum (diagonal ``W``, every barrier row holds),
        else :class:`InvalidInputError` (see ``domain.REF_RATIO_MAX``).
        """
        cur = self._cur
        uc = np.minimum(np.maximum(u0, cur.lo), cur.hi)
        if self._w_diag and (G @ uc + c0 >= 0.0).all():
            msg = (
                f"u_ref beyond {REF_RATIO_MAX:.0e} x the input scale: clipped to the limits "
                "(exact: the clip satisfies every barrier constraint)"
            )
            return make_result(uc, FilterStatus.ACTIVE, terms, G, c0, cur, "clip", t0, msg)
        raise far_reference_error(u0, cur.scale)

    def _verify(self, u, Gn, lo_rows) -> bool:
        """Every (unit-norm) row holds at ``u`` within the rounding of the numbers involved."""
        size = math.hypot(*u.tolist())  # (m <= 3: cheaper than numpy reductions)
        if not size <= FLOAT_MAX:  # NaN or inf
            return False
        tol = FEAS_TOL * (1.0 + size) + ROUND_TOL * self._umax
        return bool((Gn @ u >= lo_rows - tol).all())

    def _brake(self, x, yaw) -> np.ndarray:
        """The model's brake input, non-finite entries 0, clipped to the call's limits."""
        u = np.asarray(self.model.brake_input(x, yaw, self.brake_gain), dtype=float)
        u = np.where(np.isfinite(u), u, 0.0)
        return np.clip(u, self._cur.lo, self._cur.hi)

    def _failsafe(self, x, yaw, n, t0, message, terms=None, G=None, c0=None) -> FilterResult:
        """FAILSAFE: the brake input; the rows' numbers when known (``failsafe_result``)."""
        return failsafe_result(self._brake(x, yaw), n, self._cur, t0, message, terms, G, c0)
