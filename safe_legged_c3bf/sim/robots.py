"""Robot descriptions known to the simulator and how to load them into PyBullet.

The quadruped is the Unitree A1 model that ships with ``pybullet_data``; the biped is the
project's own URDF (``safe_legged_c3bf/description/biped.urdf``). Loading puts the robot in
torque mode: PyBullet's default velocity motors are disabled so that only the emulated motor
drivers (``motor_driver.MotorDriver``) move the joints.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np
import pybullet
import pybullet_data

from safe_legged_c3bf.interfaces.base_state import yaw_to_quaternion

DESCRIPTION_DIR = os.path.join(os.path.dirname(os.path.dirname(__file__)), "description")


@dataclass(frozen=True)
class RobotSpec:
    """Static facts about a robot model.

    Attributes:
        kind: 'quadruped' or 'biped'.
        urdf: absolute path of the URDF file.
        spawn_height: base height (m) at which the robot is spawned, feet just above ground.
        standing_pose: joint name -> angle (rad) of the nominal standing posture.
        foot_links: names of the links that touch the ground.
        width: robot width (m) used to inflate obstacles (w in r = max(c1, c2) + w/2).
        height: body height (m) used to inflate horizontal obstacles.
        trunk_top: height (m) of the trunk's top above the base origin (its collision box).
        min_base_height: lowest base height (m) the gait controller holds while walking.

    """

    kind: str
    urdf: str
    spawn_height: float
    standing_pose: dict[str, float] = field(default_factory=dict)
    foot_links: tuple[str, ...] = ()
    width: float = 0.3
    height: float = 0.2
    trunk_top: float = 0.1
    min_base_height: float = 0.0


def _a1_spec() -> RobotSpec:
    pose = {}
    for leg in ("FR", "FL", "RR", "RL"):
        pose[f"{leg}_hip_joint"] = 0.0
        pose[f"{leg}_upper_joint"] = 0.8
        pose[f"{leg}_lower_joint"] = -1.6
    return RobotSpec(
        kind="quadruped",
        urdf=os.path.join(pybullet_data.getDataPath(), "a1", "a1.urdf"),
        spawn_height=0.32,
        standing_pose=pose,
        foot_links=("FR_toe", "FL_toe", "RR_toe", "RL_toe"),
        width=0.30,
        height=0.12,
        trunk_top=0.057,  # trunk collision box 0.267 x 0.194 x 0.114 m about the base origin
        min_base_height=0.18,  # config/quadruped_controller.yaml: min_body_height
    )


def _biped_spec() -> RobotSpec:
    # Spawn posture = the gait controller's standing posture (safe_legged_c3bf.gait.biped):
    # knees bent so the hip-to-ankle distance is 0.56 m (legs 0.30 + 0.30 m), feet flat.
    # Base height = 0.06 (sole to ankle) + 0.56 + 0.20 (hips below the torso origin) + 5 mm.
    bend = float(np.arccos(0.56 / 0.60))
    pose = {}
    for side in ("l", "r"):
        pose.update(
            {
                f"{side}_hip_yaw": 0.0,
                f"{side}_hip_roll": 0.0,
                f"{side}_hip_pitch": -bend,
                f"{side}_knee": 2.0 * bend,
                f"{side}_ankle_pitch": -bend,
                f"{side}_ankle_roll": 0.0,
            }
        )
    return RobotSpec(
        kind="biped",
        urdf=os.path.join(DESCRIPTION_DIR, "biped.urdf"),
        spawn_height=0.825,
        standing_pose=pose,
        foot_links=("l_foot", "r_foot"),
        width=0.30,
        height=0.42,
        trunk_top=0.23,  # torso box 0.3 m high centred 0.08 m above the base origin
        min_base_height=0.80,  # walks at ~0.81 m and ignores vertical commands: no ducking
    )


ROBOTS = {"a1": _a1_spec, "quadruped": _a1_spec, "biped": _biped_spec}


def robot_spec(name: str) -> RobotSpec:
    """Return the spec of a robot by name ('a1'/'quadruped' or 'biped')."""
    try:
        return ROBOTS[name]()
    except KeyError:
        raise ValueError(f"unknown robot '{name}', expected one of {sorted(ROBOTS)}") from None


@dataclass
class RobotHandle:
    """A robot loaded in a PyBullet client.

    Attributes:
        body_id: PyBullet body unique id.
        spec: the robot's static description.
        joint_names: names of the actuated (revolute/prismatic) joints, in URDF order.
        joint_indices: PyBullet joint indices of those joints.
        torque_limits: (n,) absolute torque limit per actuated joint (N m), from the URDF.
        link_ids: link name -> PyBullet link index (base is -1).

    """

    body_id: int
    spec: RobotSpec
    joint_names: list[str]
    joint_indices: np.ndarray
    torque_limits: np.ndarray
    link_ids: dict[str, int]


def load_robot(
    client: int,
    name: str,
    position_xy: tuple[float, float] = (0.0, 0.0),
    yaw: float = 0.0,
    default_torque_limit: float = 30.0,
) -> RobotHandle:
    """Load a robot into ``client``, set its standing posture and disable velocity motors.

    Args:
        client: PyBullet physics client id.
        name: robot name understood by :func:`robot_spec`.
        position_xy: spawn position of the base in the world (odom) frame (m).
        yaw: spawn heading (rad).
        default_torque_limit: limit (N m) for joints whose URDF gives no effort limit.

    """
    spec = robot_spec(name)
    if not os.path.exists(spec.urdf):
        raise FileNotFoundError(f"robot description not found: {spec.urdf}")
    body = pybullet.loadURDF(
        spec.urdf,
        [float(position_xy[0]), float(position_xy[1]), spec.spawn_height],
        yaw_to_quaternion(yaw).tolist(),
        useFixedBase=False,
        flags=pybullet.URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS,
        physicsClientId=client,
    )
    names, indices, limits = [], [], []
    link_ids = {pybullet.getBodyInfo(body, physicsClientId=client)[0].decode(): -1}
    for j in range(pybullet.getNumJoints(body, physicsClientId=client)):
        info = pybullet.getJointInfo(body, j, physicsClientId=client)
        link_ids[info[12].decode()] = j
        if info[2] in (pybullet.JOINT_REVOLUTE, pybullet.JOINT_PRISMATIC):
            names.append(info[1].decode())
            indices.append(j)
            limits.append(info[10] if info[10] > 0 else default_torque_limit)
    indices_arr = np.array(indices, dtype=int)
    for name_j, idx in zip(names, indices, strict=True):
        pybullet.resetJointState(
            body, idx, spec.standing_pose.get(name_j, 0.0), 0.0, physicsClientId=client
        )
    # Torque mode: switch off the default velocity motors.
    pybullet.setJointMotorControlArray(
        body,
        indices,
        pybullet.VELOCITY_CONTROL,
        forces=[0.0] * len(indices),
        physicsClientId=client,
    )
    return RobotHandle(body, spec, names, indices_arr, np.array(limits, dtype=float), link_ids)
