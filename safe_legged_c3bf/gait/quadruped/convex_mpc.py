"""Convex model-predictive control of the body with ground reaction forces (Di Carlo 2018).

Model: one rigid body of mass ``m`` and inertia ``I`` (about the centre of mass, body axes),
state ``x = (roll, pitch, yaw, p, w, v)`` in odom axes (12), input the four feet's ground
reaction forces in odom axes (12). Linearised about zero roll and pitch, so that with the
reference yaw ``psi_k`` of step ``k``::

    d(rpy)/dt = Rz(psi)^T w,   dp/dt = v,
    dw/dt = I_w^-1 sum_i r_i x f_i,   dv/dt = sum_i f_i / m + g,   I_w = Rz I Rz^T,

with ``r_i`` from the centre of mass to foot ``i``. Because the state matrix ``A_c`` is
nilpotent (``A_c^2 = 0``) the zero-order-hold discretisation is exact and cheap:
``A = I + A_c dt``, ``B = (I dt + A_c dt^2 / 2) B_c``.

QP over ``z = (x_1..x_N, u_0..u_{N-1})`` (sparse formulation)::

    min  sum_k (x_k - x_ref_k)^T Q (x_k - x_ref_k) + u_k^T R u_k
    s.t. x_{k+1} = A_k x_k + B_k u_k + d_k        (x_0 measured)
         |f_x|, |f_y| <= mu f_z                    (pyramid friction cone)
         c_ik f_min <= f_z <= c_ik f_max           (c_ik = 1 in stance, 0 in swing)

A swing foot's force is therefore zero (its normal force is bounded to 0 and the friction
pyramid pins the tangential force to 0). The sparsity of P and A is fixed at construction;
each solve only writes new values (dynamics blocks of A, the linear cost, the bounds) into
the one OSQP solver, which warm-starts from the previous solution.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp

GRAVITY = 9.81
NX = 12
NU = 12

_SOLVED = ("solved", "solved inaccurate")


@dataclass
class MpcSolution:
    """Result of one MPC solve.

    Attributes:
        forces: (4, 3) ground reaction forces on the feet for the first step, odom axes (N).
        force_plan: (N, 4, 3) forces over the horizon (N).
        state_plan: (N, 12) predicted states x_1..x_N.
        status: OSQP status string ('fallback' when the forces were not from OSQP).
        iterations: OSQP iterations.
        solve_time: wall time of update + solve (s).
        ok: True when OSQP solved (possibly inaccurately) the problem.

    """

    forces: np.ndarray
    force_plan: np.ndarray
    state_plan: np.ndarray
    status: str
    iterations: int
    solve_time: float
    ok: bool


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def yaw_rotations(yaw: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) about z."""
    yaw = np.asarray(yaw, dtype=float).reshape(-1)
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.zeros((yaw.size, 3, 3))
    out[:, 0, 0] = c
    out[:, 0, 1] = -s
    out[:, 1, 0] = s
    out[:, 1, 1] = c
    out[:, 2, 2] = 1.0
    return out


class ConvexMpc:
    """Single-rigid-body convex MPC solved with one reused OSQP instance."""

    def __init__(
        self,
        mass: float,
        inertia: np.ndarray,
        horizon: int,
        dt: float,
        friction_coefficient: float,
        min_normal_force: float,
        max_normal_force: float,
        state_weights: np.ndarray,
        force_weight: float,
        eps_abs: float = 1e-3,
        eps_rel: float = 1e-3,
        max_iter: int = 200,
    ) -> None:
        """Build the QP structure and the OSQP solver.

        Args:
            mass: body mass (kg).
            inertia: (3, 3) inertia about the centre of mass in body axes (kg m^2).
            horizon: number of steps N.
            dt: step duration (s).
            friction_coefficient: mu of the friction pyramid.
            min_normal_force: lower bound of a stance foot's normal force (N).
            max_normal_force: upper bound of a stance foot's normal force (N).
            state_weights: (12,) diagonal of Q.
            force_weight: diagonal value of R.
            eps_abs: OSQP absolute tolerance.
            eps_rel: OSQP relative tolerance.
            max_iter: OSQP iteration limit.

        """
        self.mass = float(mass)
        self.inertia = np.asarray(inertia, dtype=float).reshape(3, 3)
        self.inertia_inv = np.linalg.inv(self.inertia)
        self.horizon = n = int(horizon)
        self.dt = float(dt)
        self.mu = float(friction_coefficient)
        self.f_min = float(min_normal_force)
        self.f_max = float(max_normal_force)
        self.q_diag = np.asarray(state_weights, dtype=float).reshape(NX)
        self.r_weight = float(force_weight)
        self.nz = n * (NX + NU)
        self._build_pattern()
        p_diag = np.concatenate(
            [np.tile(2.0 * self.q_diag, n), np.full(n * NU, 2.0 * self.r_weight)]
        )
        # a tiny regularisation keeps P positive definite when some weights are zero
        p_mat = sp.diags(p_diag + 1e-9, format="csc")
        self._q = np.zeros(self.nz)
        self._solver = osqp.OSQP()
        self._solver.setup(
            p_mat,
            self._q,
            self._a_mat,
            self._l,
            self._u,
            verbose=False,
            eps_abs=eps_abs,
            eps_rel=eps_rel,
            max_iter=max_iter,
            polishing=False,
            warm_starting=True,
            check_termination=10,
        )
        self.last_solution: MpcSolution | None = None

    # ------------------------------------------------------------------ structure
    def _build_pattern(self) -> None:
        """Create A with every structurally non-zero entry and index maps into A.data."""
        n, dt = self.horizon, self.dt
        x_col = lambda k: NX * (k - 1)  # noqa: E731  column of x_k, k = 1..N
        u_col = lambda k: NX * n + NU * k  # noqa: E731  column of u_k, k = 0..N-1
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        vals: list[np.ndarray] = []
        tags: list[np.ndarray] = []  # 0 constant, 1 rotation block, 2 B theta rows, 3 B omega

        def add(r: np.ndarray, c: np.ndarray, v: np.ndarray, tag: int) -> None:
            r, c = np.broadcast_arrays(np.asarray(r), np.asarray(c))
            rows.append(r.ravel())
            cols.append(c.ravel())
            vals.append(np.broadcast_to(np.asarray(v, dtype=float), r.shape).ravel())
            tags.append(np.full(r.size, tag))

        i3 = np.arange(3)
        i12 = np.arange(12)
        for k in range(n):
            r0 = NX * k  # rows of the dynamics x_{k+1} = A_k x_k + B_k u_k + d_k
            add(r0 + i12, x_col(k + 1) + i12, 1.0, 0)
            if k >= 1:
                c0 = x_col(k)
                add(r0 + i12, c0 + i12, -1.0, 0)
                add(r0 + i3[:, None], c0 + 6 + i3[None, :], 0.0, 1)  # -Rz^T dt (theta, w)
                add(r0 + 3 + i3, c0 + 9 + i3, -dt, 0)  # -dt (p, v)
            cu = u_col(k)
            add(r0 + i3[:, None], cu + i12[None, :], 0.0, 2)  # theta rows of -B
            add(r0 + 6 + i3[:, None], cu + i12[None, :], 0.0, 3)  # omega rows of -B
            for foot in range(4):
                add(r0 + 3 + i3, cu + 3 * foot + i3, -0.5 * dt * dt / self.mass, 0)
                add(r0 + 9 + i3, cu + 3 * foot + i3, -dt / self.mass, 0)
        n_eq = NX * n
        mu = self.mu
        friction = np.array(
            [[1.0, 0.0, -mu], [-1.0, 0.0, -mu], [0.0, 1.0, -mu], [0.0, -1.0, -mu], [0.0, 0.0, 1.0]]
        )
        for k in range(n):
            for foot in range(4):
                r0 = n_eq + 20 * k + 5 * foot
                c0 = u_col(k) + 3 * foot
                rr, cc = np.nonzero(friction)
                add(r0 + rr, c0 + cc, friction[rr, cc], 0)
        row = np.concatenate(rows)
        col = np.concatenate(cols)
        val = np.concatenate(vals)
        tag = np.concatenate(tags)
        n_con = n_eq + 20 * n
        # build with unique placeholder ids so explicit zeros survive and we find each entry
        ids = np.arange(1, row.size + 1, dtype=float)
        mat = sp.csc_matrix((ids, (row, col)), shape=(n_con, self.nz))
        mat.sort_indices()
        if mat.nnz != row.size:
            raise RuntimeError("duplicate entries in the MPC constraint pattern")
        position = np.empty(row.size, dtype=int)
        position[mat.data.astype(int) - 1] = np.arange(row.size)
        self._a_data = val[mat.data.astype(int) - 1].copy()
        mat.data = self._a_data.copy()
        self._a_mat = mat
        # index maps (into A.data) of the blocks that change with yaw and foot positions
        self._idx_rot = position[tag == 1].reshape(n - 1, 3, 3) if n > 1 else None
        self._idx_btheta = position[tag == 2].reshape(n, 3, 12)
        self._idx_bomega = position[tag == 3].reshape(n, 3, 12)
        self.n_eq = n_eq
        self.n_con = n_con
        self._l = np.zeros(n_con)
        self._u = np.zeros(n_con)
        fz_rows = n_eq + 5 * np.arange(4 * n) + 4
        fr_rows = (n_eq + 5 * np.arange(4 * n)[:, None] + np.arange(4)[None, :]).ravel()
        self._fz_rows = fz_rows
        self._l[fr_rows] = -np.inf
        self._u[fr_rows] = 0.0
        self._gravity_step = np.zeros(NX)
        self._gravity_step[5] = -0.5 * GRAVITY * dt * dt
        self._gravity_step[11] = -GRAVITY * dt

    # ------------------------------------------------------------------ solve
    def solve(
        self,
        x0: np.ndarray,
        x_ref: np.ndarray,
        yaw_ref: np.ndarray,
        foot_vectors: np.ndarray,
        contacts: np.ndarray,
    ) -> MpcSolution:
        """Solve the MPC and return the first forces and the plan.

        Args:
            x0: (12,) current state (rpy, com position, angular velocity, com velocity).
            x_ref: (N, 12) reference states x_1..x_N.
            yaw_ref: (N,) yaw used to linearise step k = 0..N-1.
            foot_vectors: (N, 4, 3) vectors from the centre of mass to each foot at step k
                (odom axes, m).
            contacts: (N, 4) bool, foot in stance at step k.

        """
        start = time.perf_counter()
        n, dt = self.horizon, self.dt
        x0 = np.asarray(x0, dtype=float)
        rz = yaw_rotations(yaw_ref)  # (N, 3, 3)
        rzt = np.swapaxes(rz, 1, 2)
        inv_iw = rz @ self.inertia_inv @ rzt  # (N, 3, 3)
        # B_c omega rows: I_w^-1 [r_i]x -> (N, 3, 12)
        b_omega = (inv_iw[:, None, :, :] @ skew(foot_vectors)).transpose(0, 2, 1, 3)
        b_omega = b_omega.reshape(n, 3, 12)
        b_theta = rzt @ b_omega
        data = self._a_data
        data[self._idx_bomega] = -dt * b_omega
        data[self._idx_btheta] = -0.5 * dt * dt * b_theta
        if self._idx_rot is not None:
            data[self._idx_rot] = -dt * rzt[1:]
        # bounds: dynamics right-hand side and contact-dependent normal force bounds
        rhs = np.tile(self._gravity_step, n)
        a0x = x0.copy()
        a0x[0:3] += dt * (rzt[0] @ x0[6:9])
        a0x[3:6] += dt * x0[9:12]
        rhs[:NX] += a0x
        self._l[: self.n_eq] = rhs
        self._u[: self.n_eq] = rhs
        c = np.asarray(contacts, dtype=bool).reshape(n * 4)
        self._l[self._fz_rows] = np.where(c, self.f_min, 0.0)
        self._u[self._fz_rows] = np.where(c, self.f_max, 0.0)
        self._q[: NX * n] = -2.0 * (np.asarray(x_ref, dtype=float) * self.q_diag).ravel()
        self._solver.update(q=self._q, l=self._l, u=self._u, Ax=data)
        result = self._solver.solve(raise_error=False)
        status = str(result.info.status)
        z = result.x
        ok = status in _SOLVED and z is not None and bool(np.all(np.isfinite(z)))
        if not ok and status == "maximum iterations reached" and z is not None:
            ok = bool(np.all(np.isfinite(z)))
        if ok:
            states = z[: NX * n].reshape(n, NX)
            force_plan = z[NX * n :].reshape(n, 4, 3).copy()
            force_plan = self._project(force_plan, contacts)
        else:
            states = np.tile(x0, (n, 1))
            force_plan = np.zeros((n, 4, 3))
            for k in range(n):
                stance = np.asarray(contacts[k], dtype=bool)
                if np.any(stance):
                    force_plan[k, stance, 2] = self.mass * GRAVITY / np.count_nonzero(stance)
            status = f"fallback ({status})"
        solution = MpcSolution(
            forces=force_plan[0].copy(),
            force_plan=force_plan,
            state_plan=states,
            status=status,
            iterations=int(result.info.iter),
            solve_time=time.perf_counter() - start,
            ok=ok,
        )
        self.last_solution = solution
        return solution

    def _project(self, forces: np.ndarray, contacts: np.ndarray) -> np.ndarray:
        """Clip forces (N, 4, 3) into the bounds and friction pyramids (solver tolerance)."""
        c = np.asarray(contacts, dtype=bool)
        fz = np.clip(forces[..., 2], 0.0, self.f_max)
        fz = np.where(c, fz, 0.0)
        lim = self.mu * fz
        forces[..., 0] = np.clip(forces[..., 0], -lim, lim)
        forces[..., 1] = np.clip(forces[..., 1], -lim, lim)
        forces[..., 2] = fz
        return forces
