"""Leg inverse/forward kinematics and the URDF-derived mass model of the biped."""

import numpy as np
import pybullet
import pytest

from safe_legged_c3bf.gait.biped.leg_ik import (
    LegGeometry,
    leg_fk,
    leg_forward,
    leg_ik,
    leg_jacobian,
    static_torques,
)
from safe_legged_c3bf.gait.biped.model import JOINT_NAMES, BipedModel
from safe_legged_c3bf.interfaces.rotations import rpy_to_matrix
from safe_legged_c3bf.sim.robots import load_robot, robot_spec

GEOM = LegGeometry((0.0, 0.09, -0.2), 0.3, 0.3, 0.06)
# joint ranges of ordinary walking (hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll)
LOW = np.array([-0.6, -0.4, -1.2, 0.1, -0.9, -0.4])
HIGH = np.array([0.6, 0.4, 0.5, 2.0, 0.6, 0.4])


@pytest.fixture(scope="module")
def model():
    return BipedModel()


def test_ik_round_trips_forward_kinematics():
    rng = np.random.default_rng(0)
    for _ in range(500):
        q = rng.uniform(LOW, HIGH)
        p, r = leg_fk(GEOM, q)
        q2 = leg_ik(GEOM, p, r)
        np.testing.assert_allclose(q2, q, atol=1e-9)


def test_fk_of_ik_reaches_random_reachable_poses():
    rng = np.random.default_rng(1)
    for _ in range(500):
        # a foot pose a realistic distance below the hip, with a tilt
        target = np.array([rng.uniform(-0.2, 0.2), 0.09 + rng.uniform(-0.1, 0.1), -0.75])
        target[2] += rng.uniform(-0.05, 0.12)
        rot = rpy_to_matrix(*rng.uniform(-0.2, 0.2, 2), rng.uniform(-0.5, 0.5))
        q = leg_ik(GEOM, target, rot)
        p, r = leg_fk(GEOM, q)
        np.testing.assert_allclose(p, target, atol=1e-9)
        np.testing.assert_allclose(r, rot, atol=1e-9)


def test_ik_of_unreachable_target_is_finite_and_stretched():
    q = leg_ik(GEOM, np.array([0.0, 0.09, -2.0]), np.eye(3), min_knee=0.05)
    assert np.all(np.isfinite(q))
    assert q[3] == pytest.approx(0.05)


def test_jacobian_matches_finite_differences():
    q = np.array([0.1, -0.05, -0.4, 0.9, -0.45, 0.03])
    jac = leg_jacobian(leg_forward(GEOM, q))
    eps = 1e-6
    for k in range(6):
        dq = np.zeros(6)
        dq[k] = eps
        p1, _ = leg_fk(GEOM, q + dq)
        p0, _ = leg_fk(GEOM, q - dq)
        np.testing.assert_allclose((p1 - p0) / (2 * eps), jac[:3, k], atol=1e-6)


def test_static_torques_balance_the_force_by_virtual_work():
    q = np.array([0.0, 0.05, -0.4, 0.8, -0.4, -0.05])
    frames = leg_forward(GEOM, q)
    force = np.array([5.0, -3.0, 200.0])
    tau = static_torques(frames, force, frames.foot_position)
    jac = leg_jacobian(frames)
    np.testing.assert_allclose(tau, -jac[:3].T @ force, atol=1e-9)


def test_model_reads_the_urdf(model):
    assert model.joint_names == JOINT_NAMES and len(JOINT_NAMES) == 12
    assert model.legs["l"].thigh == pytest.approx(0.30)
    assert model.legs["r"].hip_offset[1] == pytest.approx(-0.09)
    assert model.foot.length == pytest.approx(0.22)
    assert 20.0 < model.total_mass < 35.0


def test_model_matches_pybullet(model):
    client = pybullet.connect(pybullet.DIRECT)
    try:
        robot = load_robot(client, "biped")
        body = robot.body_id
        rng = np.random.default_rng(2)
        q = rng.uniform(np.tile(LOW, 2), np.tile(HIGH, 2))
        index = dict(zip(robot.joint_names, robot.joint_indices, strict=True))
        for name, value in zip(model.joint_names, q, strict=True):
            pybullet.resetJointState(body, int(index[name]), value, physicsClientId=client)
        pybullet.resetBasePositionAndOrientation(
            body, [0, 0, 1], [0, 0, 0, 1], physicsClientId=client
        )
        total, mass = np.zeros(3), 0.0
        for j in range(-1, pybullet.getNumJoints(body, physicsClientId=client)):
            m = pybullet.getDynamicsInfo(body, j, physicsClientId=client)[0]
            if j < 0:
                pos = pybullet.getBasePositionAndOrientation(body, physicsClientId=client)[0]
            else:
                pos = pybullet.getLinkState(body, j, physicsClientId=client)[0]
            total += m * np.array(pos)
            mass += m
        np.testing.assert_allclose(total / mass - [0, 0, 1], model.com(q), atol=1e-6)
        for i, side in enumerate("lr"):
            frames = model.leg_frames(side, q[6 * i : 6 * i + 6])
            state = pybullet.getLinkState(
                body, robot.link_ids[f"{side}_foot"], physicsClientId=client
            )
            np.testing.assert_allclose(
                np.array(state[4]) - [0, 0, 1], frames.positions[5], atol=1e-6
            )
            rot = np.array(pybullet.getMatrixFromQuaternion(state[5])).reshape(3, 3)
            np.testing.assert_allclose(rot, frames.foot_rotation, atol=1e-6)
        # joint-space inertia and gravity torques of a fixed-base copy
        fixed = pybullet.loadURDF(
            robot.spec.urdf, [0, 0, 1], useFixedBase=True, physicsClientId=client
        )
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        order = [robot.joint_names.index(n) for n in model.joint_names]
        q_pb = [0.0] * 12
        for k, i in enumerate(order):
            q_pb[i] = q[k]
        mass_matrix = np.array(pybullet.calculateMassMatrix(fixed, q_pb, physicsClientId=client))
        gravity = np.array(
            pybullet.calculateInverseDynamics(
                fixed, q_pb, [0.0] * 12, [0.0] * 12, physicsClientId=client
            )
        )
        for i, side in enumerate("lr"):
            frames = model.leg_frames(side, q[6 * i : 6 * i + 6])
            idx = np.array(order[6 * i : 6 * i + 6])
            np.testing.assert_allclose(
                model.leg_mass_matrix(side, frames), mass_matrix[np.ix_(idx, idx)], atol=2e-3
            )
            np.testing.assert_allclose(
                model.leg_gravity_torques(side, frames, np.array([0, 0, -9.81])),
                gravity[idx],
                atol=1e-6,
            )
    finally:
        pybullet.disconnect(client)


def test_spawn_posture_is_the_standing_posture(model):
    spec = robot_spec("biped")
    q = np.array([spec.standing_pose[n] for n in model.joint_names])
    for i, side in enumerate("lr"):
        frames = model.leg_frames(side, q[6 * i : 6 * i + 6])
        # feet flat, straight under the hips, soles 5 mm above the ground at spawn
        np.testing.assert_allclose(frames.foot_rotation, np.eye(3), atol=1e-9)
        assert frames.foot_position[0] == pytest.approx(0.0, abs=1e-9)
        assert spec.spawn_height + frames.foot_position[2] == pytest.approx(0.005, abs=1e-6)
