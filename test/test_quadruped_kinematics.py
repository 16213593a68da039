"""A1 leg kinematics: forward/inverse/Jacobian against finite differences and PyBullet."""

from __future__ import annotations

import numpy as np
import pybullet
import pytest

from safe_legged_c3bf.gait.quadruped import a1_kinematics as kin
from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams
from safe_legged_c3bf.sim.robots import load_robot


def _random_configurations(n: int, seed: int = 0) -> np.ndarray:
    """Joint configurations in the working range: within the joint limits, knee bent, every
    foot at least 5 cm below its thigh joint and away from singular configurations."""
    rng = np.random.default_rng(seed)
    lo = np.tile([-0.6, -0.6, -2.5], 4)
    hi = np.tile([0.6, 1.8, -1.0], 4)
    out = []
    while len(out) < n:
        q = rng.uniform(lo, hi)
        legs = q.reshape(4, 3)
        sagittal_z = -0.2 * np.cos(legs[:, 1]) - 0.2 * np.cos(legs[:, 1] + legs[:, 2])
        dets = np.linalg.det(kin.foot_jacobians(q))
        if np.all(sagittal_z < -0.05) and np.all(np.abs(dets) > 1e-3):
            out.append(q)
    return np.array(out)


@pytest.fixture(scope="module")
def a1():
    """An A1 floating in a DIRECT client (no gravity), with its link ids."""
    client = pybullet.connect(pybullet.DIRECT)
    robot = load_robot(client, "a1", (0.3, -0.2), yaw=0.7)
    yield client, robot
    pybullet.disconnect(client)


def _set_pose(client, robot, q, position, quat):
    """Put the base_link at ``position``/``quat`` (PyBullet places the base CoM) and set q."""
    body = robot.body_id
    com_local = np.array(pybullet.getDynamicsInfo(body, -1, physicsClientId=client)[3])
    rot = np.array(pybullet.getMatrixFromQuaternion(quat)).reshape(3, 3)
    pybullet.resetBasePositionAndOrientation(
        body, (position + rot @ com_local).tolist(), quat, physicsClientId=client
    )
    for value, index in zip(q, robot.joint_indices, strict=True):
        pybullet.resetJointState(body, int(index), float(value), physicsClientId=client)
    return rot


def test_joint_order_matches_urdf(a1):
    _, robot = a1
    assert robot.joint_names == kin.JOINT_NAMES


def test_standing_pose_feet_below_thigh_joints():
    feet = kin.forward_kinematics(kin.STANDING_POSE)
    expected_z = -2 * 0.2 * np.cos(0.8)
    np.testing.assert_allclose(feet[:, 2], expected_z, atol=1e-12)
    np.testing.assert_allclose(feet[:, 0], kin.HIP_POSITIONS[:, 0], atol=1e-12)
    np.testing.assert_allclose(
        feet[:, 1], kin.HIP_POSITIONS[:, 1] + kin.SIDE_SIGN * kin.HIP_OFFSET, atol=1e-12
    )


def test_forward_kinematics_matches_pybullet(a1):
    client, robot = a1
    position = np.array([0.3, -0.2, 0.5])
    quat = pybullet.getQuaternionFromEuler([0.1, -0.15, 0.7])
    for q in _random_configurations(20):
        rot = _set_pose(client, robot, q, position, quat)
        toes = np.array(
            [
                pybullet.getLinkState(
                    robot.body_id,
                    robot.link_ids[f"{leg}_toe"],
                    computeForwardKinematics=True,
                    physicsClientId=client,
                )[4]
                for leg in kin.LEG_NAMES
            ]
        )
        feet_body = (toes - position) @ rot
        np.testing.assert_allclose(kin.forward_kinematics(q), feet_body, atol=1e-6)


def test_jacobian_matches_pybullet(a1):
    client, robot = a1
    position = np.array([0.0, 0.0, 0.5])
    quat = pybullet.getQuaternionFromEuler([0.2, 0.1, -0.4])
    zeros = [0.0] * 12
    for q in _random_configurations(5, seed=1):
        _set_pose(client, robot, q, position, quat)
        jac = kin.foot_jacobians(q)
        for i, leg in enumerate(kin.LEG_NAMES):
            linear, _ = pybullet.calculateJacobian(
                robot.body_id,
                robot.link_ids[f"{leg}_toe"],
                [0.0, 0.0, 0.0],
                q.tolist(),
                zeros,
                zeros,
                physicsClientId=client,
            )
            # floating base: 6 base columns first; PyBullet gives the joint columns in the
            # base's own axes, i.e. base_link (the base's inertial frame is not rotated)
            joint_cols = np.array(linear)[:, 6 + 3 * i : 9 + 3 * i]
            np.testing.assert_allclose(joint_cols, jac[i], atol=1e-9)


def test_jacobian_matches_finite_differences():
    eps = 1e-6
    for q in _random_configurations(10, seed=2):
        jac = kin.foot_jacobians(q)
        for j in range(12):
            dq = np.zeros(12)
            dq[j] = eps
            diff = (kin.forward_kinematics(q + dq) - kin.forward_kinematics(q - dq)) / (2 * eps)
            leg, col = divmod(j, 3)
            np.testing.assert_allclose(diff[leg], jac[leg][:, col], atol=1e-7)
            others = [k for k in range(4) if k != leg]
            np.testing.assert_allclose(diff[others], 0.0, atol=1e-12)


def test_inverse_kinematics_round_trip():
    for q in _random_configurations(50, seed=3):
        feet = kin.forward_kinematics(q)
        q_ik = kin.inverse_kinematics(feet)
        np.testing.assert_allclose(q_ik, q, atol=1e-8)
        for leg in range(4):
            np.testing.assert_allclose(
                kin.leg_inverse_kinematics(leg, feet[leg]), q[3 * leg : 3 * leg + 3], atol=1e-8
            )


def test_inverse_kinematics_of_nominal_stance_and_unreachable_targets():
    feet = kin.nominal_foot_positions(0.28)
    q = kin.inverse_kinematics(feet)
    np.testing.assert_allclose(kin.forward_kinematics(q) - feet, 0.0, atol=1e-9)
    far = feet.copy()
    far[:, 2] = -1.0  # beyond the 0.4 m reach
    q_far = kin.inverse_kinematics(far)
    assert np.all(np.isfinite(q_far))
    assert np.all(q_far >= kin.JOINT_LOWER) and np.all(q_far <= kin.JOINT_UPPER)
    reached = kin.forward_kinematics(q_far)
    assert np.all(reached[:, 2] < -0.3)  # as far down as the knee limit lets it


def test_jacobian_inverses():
    for q in _random_configurations(10, seed=4):
        jac = kin.foot_jacobians(q)
        identity = np.broadcast_to(np.eye(3), (4, 3, 3))
        np.testing.assert_allclose(kin.jacobian_inverses(jac) @ jac, identity, atol=1e-9)
    # a stretched leg (knee straight) is singular: the damped inverse stays bounded
    q = kin.STANDING_POSE.copy()
    q[2] = -1e-9
    inv = kin.jacobian_inverses(kin.foot_jacobians(q))
    assert np.all(np.isfinite(inv)) and np.abs(inv).max() < 1e4
    v = np.array([[0.1, 0.0, 0.0]] * 4)
    dq = kin.solve_leg_velocities(kin.foot_jacobians(kin.STANDING_POSE), v)
    np.testing.assert_allclose(
        (kin.foot_jacobians(kin.STANDING_POSE) @ dq.reshape(4, 3, 1))[..., 0], v, atol=1e-12
    )


def test_gravity_torques_match_pybullet_inverse_dynamics():
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        import pybullet_data

        body = pybullet.loadURDF(
            pybullet_data.getDataPath() + "/a1/a1.urdf", useFixedBase=True, physicsClientId=client
        )
        zeros = [0.0] * 12
        for q in _random_configurations(5, seed=5):
            tau = pybullet.calculateInverseDynamics(
                body, q.tolist(), zeros, zeros, physicsClientId=client
            )
            # the 1 g "upper_shoulder" collision links are ignored by the model
            np.testing.assert_allclose(kin.gravity_torques(q, (0, 0, -9.81)), tau, atol=2e-3)
    finally:
        pybullet.disconnect(client)


def test_lumped_body_parameters_match_pybullet(a1):
    """Mass, CoM offset and inertia in QuadrupedParams are those PyBullet simulates."""
    client, robot = a1
    body = robot.body_id
    _set_pose(client, robot, kin.STANDING_POSE, np.zeros(3), [0, 0, 0, 1])
    masses, coms, inertias = [], [], []
    for link in range(-1, pybullet.getNumJoints(body, physicsClientId=client)):
        info = pybullet.getDynamicsInfo(body, link, physicsClientId=client)
        if link == -1:
            pos, orn = pybullet.getBasePositionAndOrientation(body, physicsClientId=client)
        else:
            state = pybullet.getLinkState(
                body, link, computeForwardKinematics=True, physicsClientId=client
            )
            pos, orn = state[0], state[1]
        rot = np.array(pybullet.getMatrixFromQuaternion(orn)).reshape(3, 3)
        masses.append(info[0])
        coms.append(np.array(pos))
        inertias.append(rot @ np.diag(info[2]) @ rot.T)
    masses = np.array(masses)
    total = masses.sum()
    com = (masses[:, None] * np.array(coms)).sum(axis=0) / total
    inertia = np.zeros((3, 3))
    for m, c, i_link in zip(masses, coms, inertias, strict=True):
        d = c - com
        inertia += i_link + m * (d @ d * np.eye(3) - np.outer(d, d))
    params = QuadrupedParams()
    assert params.mass == pytest.approx(total, rel=1e-3)
    np.testing.assert_allclose(params.com_offset, com, atol=5e-4)
    np.testing.assert_allclose(np.array(params.inertia).reshape(3, 3), inertia, atol=2e-3)
