"""Convex MPC on model problems: standing, two-leg stance, tracking, solver reuse."""

from __future__ import annotations

import numpy as np
import pytest

from safe_legged_c3bf.gait.quadruped import a1_kinematics as kin
from safe_legged_c3bf.gait.quadruped.convex_mpc import GRAVITY, ConvexMpc, skew, yaw_rotations
from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams

HEIGHT = 0.28


def make_mpc(params: QuadrupedParams | None = None, eps: float = 1e-6) -> ConvexMpc:
    """The MPC of ``params``, solved tightly by default to test the formulation."""
    p = params or QuadrupedParams()
    weights = np.concatenate(
        [
            p.weight_orientation,
            p.weight_position,
            p.weight_angular_velocity,
            p.weight_linear_velocity,
        ]
    )
    return ConvexMpc(
        p.mass,
        np.array(p.inertia).reshape(3, 3),
        p.mpc_horizon,
        p.mpc_dt,
        p.friction_coefficient,
        p.min_normal_force,
        p.max_normal_force,
        weights,
        p.weight_force,
        eps_abs=eps,
        eps_rel=eps,
        max_iter=4000,
    )


def standing_problem(mpc: ConvexMpc, yaw: float = 0.0, com_xy=(0.0, 0.0)):
    """State at rest at the nominal height; feet below the thigh joints, odom axes."""
    n = mpc.horizon
    com = np.array([com_xy[0], com_xy[1], HEIGHT - 0.02])
    x0 = np.zeros(12)
    x0[2] = yaw
    x0[3:6] = com
    rot = yaw_rotations([yaw])[0]
    feet = (kin.nominal_foot_positions(HEIGHT) @ rot.T) + np.array([com_xy[0], com_xy[1], HEIGHT])
    feet_vectors = np.broadcast_to(feet - com, (n, 4, 3)).copy()
    x_ref = np.tile(x0, (n, 1))
    return x0, x_ref, np.full(n, yaw), feet_vectors


def assert_in_cones(forces: np.ndarray, mu: float, stance: np.ndarray) -> None:
    tol = 1e-3
    assert np.all(forces[stance, 2] >= -tol)
    assert np.all(np.abs(forces[:, 0]) <= mu * forces[:, 2] + tol)
    assert np.all(np.abs(forces[:, 1]) <= mu * forces[:, 2] + tol)
    np.testing.assert_allclose(forces[~stance], 0.0, atol=1e-9)


@pytest.mark.parametrize("yaw", [0.0, 1.2])
def test_standing_forces_carry_the_weight(yaw):
    mpc = make_mpc()
    x0, x_ref, yaws, feet = standing_problem(mpc, yaw)
    contacts = np.ones((mpc.horizon, 4), dtype=bool)
    sol = mpc.solve(x0, x_ref, yaws, feet, contacts)
    assert sol.ok and sol.status == "solved"
    weight = mpc.mass * GRAVITY
    assert sol.forces[:, 2].sum() == pytest.approx(weight, rel=0.01)
    np.testing.assert_allclose(sol.forces[:, :2].sum(axis=0), 0.0, atol=0.01 * weight)
    assert_in_cones(sol.forces, mpc.mu, np.ones(4, dtype=bool))
    # the plan holds the body up (the last steps, without terminal cost, matter little and
    # are solved loosely) and the predicted state stays at rest
    np.testing.assert_allclose(sol.force_plan[:3, :, 2].sum(axis=1), weight, rtol=0.03)
    for k in range(mpc.horizon):
        assert_in_cones(sol.force_plan[k], mpc.mu, np.ones(4, dtype=bool))
    np.testing.assert_allclose(sol.state_plan[:, 3:6], x_ref[:, 3:6], atol=2e-3)
    # the net moment about the centre of mass vanishes (feet symmetric about the CoM)
    moment = np.cross(feet[0], sol.forces).sum(axis=0)
    np.testing.assert_allclose(moment, 0.0, atol=0.05)


def test_default_tolerances_are_close_enough():
    """The controller's looser OSQP tolerances still balance the weight within 3 %."""
    p = QuadrupedParams()
    mpc = make_mpc(p, eps=p.osqp_eps_abs)
    x0, x_ref, yaws, feet = standing_problem(mpc)
    for contacts in (np.ones(4, dtype=bool), np.array([True, False, False, True])):
        plan = np.tile(contacts, (mpc.horizon, 1))
        for _ in range(3):  # warm-started re-solves, as in the controller
            sol = mpc.solve(x0, x_ref, yaws, feet, plan)
        assert sol.ok
        assert sol.forces[:, 2].sum() == pytest.approx(mpc.mass * GRAVITY, rel=0.03)
        assert_in_cones(sol.forces, mpc.mu, contacts)


def test_two_leg_stance_zero_swing_forces():
    mpc = make_mpc()
    x0, x_ref, yaws, feet = standing_problem(mpc)
    diagonal = np.array([True, False, False, True])  # FR + RL in stance
    contacts = np.tile(diagonal, (mpc.horizon, 1))
    sol = mpc.solve(x0, x_ref, yaws, feet, contacts)
    assert sol.ok
    assert sol.forces[diagonal, 2].sum() == pytest.approx(mpc.mass * GRAVITY, rel=0.01)
    assert_in_cones(sol.forces, mpc.mu, diagonal)
    for k in range(mpc.horizon):
        assert_in_cones(sol.force_plan[k], mpc.mu, contacts[k])


def test_forward_velocity_reference_pushes_forward():
    mpc = make_mpc()
    x0, x_ref, yaws, feet = standing_problem(mpc)
    x_ref[:, 9] = 0.5
    x_ref[:, 3] = 0.5 * mpc.dt * np.arange(1, mpc.horizon + 1)
    sol = mpc.solve(x0, x_ref, yaws, feet, np.ones((mpc.horizon, 4), dtype=bool))
    assert sol.ok
    assert sol.forces[:, 0].sum() > 5.0
    assert sol.state_plan[-1, 9] > 0.2
    assert_in_cones(sol.forces, mpc.mu, np.ones(4, dtype=bool))


def test_yaw_rate_reference_turns_left():
    mpc = make_mpc()
    x0, x_ref, yaws, feet = standing_problem(mpc)
    x_ref[:, 8] = 0.5
    x_ref[:, 2] = 0.5 * mpc.dt * np.arange(1, mpc.horizon + 1)
    sol = mpc.solve(x0, x_ref, yaws, feet, np.ones((mpc.horizon, 4), dtype=bool))
    assert sol.ok
    moment_z = np.cross(feet[0], sol.forces).sum(axis=0)[2]
    assert moment_z > 0.1
    assert sol.state_plan[-1, 8] > 0.1


def test_predictions_follow_the_discrete_model():
    """x_{k+1} = A_k x_k + B_k u_k + d_k with the exact (A_c^2 = 0) zero-order hold."""
    mpc = make_mpc()
    x0, x_ref, yaws, feet = standing_problem(mpc, yaw=0.4)
    x0[6:9] = (0.1, -0.2, 0.3)
    x0[9:12] = (0.2, 0.1, -0.05)
    x_ref[:, 9] = 0.3
    sol = mpc.solve(x0, x_ref, yaws, feet, np.ones((mpc.horizon, 4), dtype=bool))
    dt = mpc.dt
    x = x0.copy()
    for k in range(mpc.horizon):
        rz = yaw_rotations([yaws[k]])[0]
        inv_iw = rz @ mpc.inertia_inv @ rz.T
        u = sol.force_plan[k]
        omega_dot = inv_iw @ sum(skew(feet[k, i]) @ u[i] for i in range(4))
        v_dot = u.sum(axis=0) / mpc.mass + np.array([0.0, 0.0, -GRAVITY])
        nxt = x.copy()
        nxt[0:3] += rz.T @ (x[6:9] * dt + 0.5 * dt * dt * omega_dot)
        nxt[3:6] += x[9:12] * dt + 0.5 * dt * dt * v_dot
        nxt[6:9] += omega_dot * dt
        nxt[9:12] += v_dot * dt
        # projection of the forces onto the cones may move them by the solver tolerance
        np.testing.assert_allclose(sol.state_plan[k], nxt, atol=5e-3)
        x = sol.state_plan[k]


def test_solver_is_reused_with_fixed_sparsity():
    mpc = make_mpc()
    solver = mpc._solver
    nnz = mpc._a_mat.nnz
    rng = np.random.default_rng(0)
    for i in range(20):
        yaw = rng.uniform(-np.pi, np.pi)
        x0, x_ref, yaws, feet = standing_problem(mpc, yaw, rng.uniform(-1, 1, 2))
        feet += rng.normal(0.0, 0.02, feet.shape)
        phase = i % 2
        contacts = np.tile([phase == 0, phase == 1, phase == 1, phase == 0], (mpc.horizon, 1))
        sol = mpc.solve(x0, x_ref, yaws, feet, contacts)
        assert sol.ok
        assert mpc._solver is solver
        assert mpc._a_mat.nnz == nnz
        assert_in_cones(sol.forces, mpc.mu, contacts[0])
    assert mpc.last_solution is sol


def test_fallback_when_unsolvable():
    """No stance foot at all and a far reference: still returns finite (zero) forces."""
    mpc = make_mpc()
    x0, x_ref, yaws, feet = standing_problem(mpc)
    sol = mpc.solve(x0, x_ref, yaws, feet, np.zeros((mpc.horizon, 4), dtype=bool))
    assert np.all(np.isfinite(sol.forces))
    np.testing.assert_allclose(sol.forces, 0.0, atol=1e-9)
