"""The simulated world without ROS: PyBullet, one legged robot, kinematic obstacles.

:class:`Simulation` loads a scenario (ground plane, robot in its standing posture, obstacles),
advances physics in fixed steps with the emulated motor drivers applying the latest joint
command at every step, and exposes the robot state, the true obstacle states, noisy
detections, LiDAR scans and 3-D point clouds (:mod:`.range_sensors`), ground truth (contacts,
minimum distance, collisions, falls), a run summary and follow-camera frames.

Determinism: for a given scenario, seed, physics step and sequence of (step index, command)
pairs, every output is identical from run to run (PyBullet is deterministic on one machine
with ``deterministicOverlappingPairs``; obstacle motion is a pure function of time; the
perception noise comes from a generator seeded by the scenario seed and consumes a fixed
number of draws per frame, and so does each range sensor's). What is *not* deterministic is
anything that depends on wall clock, e.g. when a ROS node applies commands relative to
physics steps outside lockstep mode.

Typical use::

    with Simulation("quadruped_default") as sim:
        sim.set_command(command)
        while not sim.finished:
            sim.step(2)
            state = sim.base_state()
        print(sim.summary())
"""

from __future__ import annotations

import array
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pybullet
import pybullet_data
from numpy.typing import ArrayLike

from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.joint_command import JointCommand
from safe_legged_c3bf.interfaces.rotations import rotate_inverse
from safe_legged_c3bf.interfaces.sensor_mounts import DEPTH_FRAME, LIDAR_FRAME, default_mounts
from safe_legged_c3bf.sim.camera import CameraConfig, FollowCamera
from safe_legged_c3bf.sim.goal_progress import GoalProgress
from safe_legged_c3bf.sim.ground_truth import GroundTruthMonitor, GroundTruthSample
from safe_legged_c3bf.sim.motor_driver import DriverMode, MotorDriver
from safe_legged_c3bf.sim.obstacle_sync import ObstacleSync
from safe_legged_c3bf.sim.obstacles import KinematicObstacle, ObstacleState
from safe_legged_c3bf.sim.perception import PerceptionModel
from safe_legged_c3bf.sim.range_sensors import DepthSensor, Lidar2D
from safe_legged_c3bf.sim.robots import load_robot
from safe_legged_c3bf.sim.run_summary import run_summary, write_json
from safe_legged_c3bf.sim.scenario import Scenario, load_scenario


@dataclass(frozen=True)
class JointStateSample:
    """Measured joint state, in the robot's joint order.

    Attributes:
        names: joint names.
        position: (n,) joint angles (rad).
        velocity: (n,) joint velocities (rad/s).
        effort: (n,) torques applied during the last physics step (N m).
        stamp: sim time (s).

    """

    names: list[str]
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray
    stamp: float


def _float_list(values: ArrayLike, n: int) -> list[float]:
    """``values`` as n floats (one value is repeated n times), as :class:`JointCommand` does.

    Raises ValueError for any other size.
    """
    if isinstance(values, array.array) and values.typecode == "d":  # as rclpy gives them
        out = values.tolist()
    else:
        out = np.asarray(values, dtype=float).reshape(-1).tolist()
    if len(out) == 1 and n != 1:
        out = out * n
    if len(out) != n:
        raise ValueError(f"{len(out)} entries for {n} joints")
    return out


class Simulation:
    """A deterministic PyBullet world built from a scenario (no ROS)."""

    def __init__(
        self,
        scenario: Scenario | str | os.PathLike[str],
        *,
        physics_dt: float = 0.001,
        gui: bool = False,
        seed: int | None = None,
        command_timeout: float = 0.1,
        damping_kd: float = 1.0,
        obstacle_sync_steps: int = 10,
        mesh_segments: int = 32,
    ) -> None:
        """Build the world.

        Args:
            scenario: a :class:`Scenario`, a scenario name or a path.
            physics_dt: physics step (s).
            gui: open PyBullet's GUI instead of a headless (DIRECT) client.
            seed: overrides the scenario's seed.
            command_timeout: sim time (s) without a new command before the drivers damp.
            damping_kd: damping gain of the drivers' damping mode (N m s / rad).
            obstacle_sync_steps: moving obstacles are re-placed on their script at least every
                this many steps (and at every velocity change); PyBullet integrates their
                velocity in between.
            mesh_segments: vertices per ring of the obstacles' ellipse polygons.

        """
        if not physics_dt > 0:
            raise ValueError("physics_dt must be positive")
        if obstacle_sync_steps < 1 or mesh_segments < 8:
            raise ValueError("obstacle_sync_steps must be >= 1 and mesh_segments >= 8")
        self.scenario = load_scenario(scenario)
        self.seed = self.scenario.seed if seed is None else int(seed)
        self.physics_dt = float(physics_dt)
        self._total_steps = int(round(self.scenario.duration / self.physics_dt))
        self.client = pybullet.connect(pybullet.GUI if gui else pybullet.DIRECT)
        if self.client < 0:
            raise RuntimeError("cannot connect to PyBullet" + (" GUI" if gui else ""))
        try:
            self._build(command_timeout, damping_kd, obstacle_sync_steps, mesh_segments)
        except Exception:
            pybullet.disconnect(self.client)
            raise

    def _build(
        self, command_timeout: float, damping_kd: float, sync_steps: int, mesh_segments: int
    ) -> None:
        sc, c = self.scenario, self.client
        pybullet.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        pybullet.setPhysicsEngineParameter(
            fixedTimeStep=self.physics_dt, deterministicOverlappingPairs=1, physicsClientId=c
        )
        pybullet.setGravity(0.0, 0.0, -sc.physics.gravity, physicsClientId=c)
        self.plane_id = pybullet.loadURDF("plane.urdf", physicsClientId=c)
        pybullet.changeDynamics(
            self.plane_id, -1, lateralFriction=sc.physics.lateral_friction, physicsClientId=c
        )
        self.robot = load_robot(c, sc.robot.model, sc.robot.position, sc.robot.yaw)
        # PyBullet reports the base's centre of mass frame; base_link is the URDF link frame.
        info = pybullet.getDynamicsInfo(self.robot.body_id, -1, physicsClientId=c)
        self._com_to_link = pybullet.invertTransform(info[3], info[4])
        self.driver = MotorDriver(c, self.robot, timeout=command_timeout, damping_kd=damping_kd)
        self._joint_indices = self.robot.joint_indices.tolist()  # a list is faster to parse
        self.obstacles = [KinematicObstacle(c, o, mesh_segments) for o in sc.obstacles]
        self._obstacle_sync = ObstacleSync(self.obstacles, sync_steps, self.physics_dt)
        self.monitor = GroundTruthMonitor(
            c, self.robot, self.obstacles, sc.ground_truth, self.physics_dt
        )
        seeds = np.random.SeedSequence(self.seed)
        (perception_seed,) = seeds.spawn(1)
        self.perception = PerceptionModel(sc.perception, perception_seed)
        lidar_seed, depth_seed = seeds.spawn(2)  # after the perception's: its stream is kept
        mounts = default_mounts(self.robot.spec.kind)
        body = self.robot.body_id
        self.lidar = Lidar2D(c, sc.perception.lidar, mounts[LIDAR_FRAME], lidar_seed, body)
        self.depth = DepthSensor(c, sc.perception.depth, mounts[DEPTH_FRAME], depth_seed, body)
        self._step = 0
        self._driver_mode = DriverMode.WAITING
        self.driver_timeouts = 0
        self.driver_timeout_times: list[float] = []  # sim s of the first few (diagnosis)
        self.commands_received = 0
        self.malformed_commands = 0
        self.goal_progress = GoalProgress(sc.goal.position, sc.goal.tolerance)
        self._camera: FollowCamera | None = None
        self._record_every = 0
        self._frames: list[np.ndarray] = []
        self._closed = False
        self.monitor.update(0.0, self._obstacle_sync.centers)
        self._update_goal(0.0)

    # ------------------------------------------------------------------ properties

    @property
    def time(self) -> float:
        """Sim time (s): physics steps taken times the step."""
        return self._step * self.physics_dt

    @property
    def step_count(self) -> int:
        """Physics steps taken."""
        return self._step

    @property
    def total_steps(self) -> int:
        """Physics steps in the scenario's duration."""
        return self._total_steps

    @property
    def finished(self) -> bool:
        """Whether the scenario duration has been reached."""
        return self._step >= self._total_steps

    @property
    def joint_names(self) -> list[str]:
        """Actuated joint names, in the order of :meth:`joint_state`."""
        return list(self.robot.joint_names)

    @property
    def driver_mode(self) -> DriverMode:
        """Mode of the motor drivers during the last step (WAITING before any command)."""
        return self._driver_mode

    @property
    def rejected_commands(self) -> int:
        """Commands rejected (non-finite, negative gains, unknown joints, wrong sizes)."""
        return self.driver.rejected_commands + self.malformed_commands

    @property
    def ground_truth(self) -> GroundTruthSample:
        """Ground truth after the latest physics step."""
        assert self.monitor.last is not None
        return self.monitor.last

    @property
    def collision_count(self) -> int:
        """Collision events so far."""
        return self.monitor.collision_count

    # ------------------------------------------------------------------ commands and stepping

    def set_command(self, command: JointCommand) -> bool:
        """Hand a motor command to the drivers at the current sim time; False if rejected."""
        accepted = self.driver.set_command(command, self.time)
        if accepted:
            self.commands_received += 1
        return accepted

    def set_command_arrays(
        self,
        names: Sequence[str],
        q: ArrayLike,
        dq: ArrayLike,
        kp: ArrayLike,
        kd: ArrayLike,
        tau: ArrayLike,
    ) -> bool:
        """Like :meth:`set_command` from raw arrays (each len(names) long, or 1 to broadcast).

        Malformed commands (array sizes that do not match) are rejected and counted.
        """
        n = len(names)
        try:
            columns = [_float_list(v, n) for v in (q, dq, kp, kd, tau)]
        except (ValueError, TypeError):
            self.malformed_commands += 1
            return False
        accepted = self.driver.set_targets(names, *columns, self.time)
        if accepted:
            self.commands_received += 1
        return accepted

    def step(self, n: int = 1) -> None:
        """Advance physics by ``n`` steps (continues past the duration if asked to)."""
        dt, client = self.physics_dt, self.client
        driver, monitor, sync = self.driver, self.monitor, self._obstacle_sync
        for _ in range(int(n)):
            k = self._step
            t = k * dt
            driver.apply(t)
            mode = driver.mode
            if mode is not self._driver_mode:
                if mode is DriverMode.DAMPING and self._driver_mode is DriverMode.ACTIVE:
                    self.driver_timeouts += 1
                    if len(self.driver_timeout_times) < 20:
                        self.driver_timeout_times.append(round(t, 3))
                self._driver_mode = mode
            sync.before_step(k, t)
            pybullet.stepSimulation(physicsClientId=client)
            k += 1
            self._step = k
            t = k * dt
            sync.after_step()
            monitor.update(t, sync.centers)
            self._update_goal(t)
            if self._record_every and k % self._record_every == 0:
                self._frames.append(self.render_frame())

    def _update_goal(self, t: float) -> None:
        pos, _ = self._link_pose(self.monitor.last_base_position, self.monitor.last_base_quaternion)
        self.goal_progress.update(t, pos)

    # ------------------------------------------------------------------ state

    def base_state(self) -> BaseState:
        """True base state: pose in odom (= world), twist in base_link, stamped now."""
        pos, quat, lin, ang = self.base_pose_twist()
        return BaseState(pos, quat, lin, ang, self.time)

    def base_pose_twist(self) -> tuple[tuple[float, ...], ...]:
        """(position, quaternion xyzw, linear velocity, angular velocity) as float tuples.

        Pose of base_link (the URDF base frame, not PyBullet's centre-of-mass frame) in odom
        (= world); the velocity of the base_link origin and the angular velocity, both
        expressed in base_link. A fast path of :meth:`base_state` for publishing (no numpy).
        """
        body, c = self.robot.body_id, self.client
        com, com_quat = pybullet.getBasePositionAndOrientation(body, physicsClientId=c)
        lin, ang = pybullet.getBaseVelocity(body, physicsClientId=c)
        pos, quat = self._link_pose(com, com_quat)
        # Velocity of the link origin: v_com + w x (p_link - p_com).
        lx, ly, lz = pos[0] - com[0], pos[1] - com[1], pos[2] - com[2]
        v = (
            lin[0] + ang[1] * lz - ang[2] * ly,
            lin[1] + ang[2] * lx - ang[0] * lz,
            lin[2] + ang[0] * ly - ang[1] * lx,
        )
        return pos, quat, rotate_inverse(quat, v), rotate_inverse(quat, ang)

    def _link_pose(
        self, com: Sequence[float], com_quat: Sequence[float]
    ) -> tuple[tuple[float, ...], tuple[float, ...]]:
        inv_pos, inv_quat = self._com_to_link
        return pybullet.multiplyTransforms(com, com_quat, inv_pos, inv_quat)

    def joint_state(self) -> JointStateSample:
        """Measured joint positions, velocities and last applied torques."""
        q, dq, tau = self.joint_lists()
        return JointStateSample(
            list(self.robot.joint_names), np.array(q), np.array(dq), np.array(tau), self.time
        )

    def joint_lists(self) -> tuple[list[float], list[float], list[float]]:
        """(positions, velocities, last torques) as plain lists: a fast path for publishing."""
        states = pybullet.getJointStates(
            self.robot.body_id, self._joint_indices, physicsClientId=self.client
        )
        return [s[0] for s in states], [s[1] for s in states], self.driver.last_torques.tolist()

    def obstacle_states(self) -> list[ObstacleState]:
        """True obstacle states now (scripted pose and velocity, VELOCITY_MEASURED)."""
        t = self.time
        return [o.state(t) for o in self.obstacles]

    def detections(self, include_ids: bool = True) -> list[ObstacleState]:
        """One simulated perception frame now (noisy, with drop-outs; consumes random draws)."""
        pos, _ = pybullet.getBasePositionAndOrientation(
            self.robot.body_id, physicsClientId=self.client
        )
        return self.perception.detect(
            self.obstacles, self.obstacle_states(), np.asarray(pos), include_ids
        )

    def lidar_scan(self) -> np.ndarray:
        """One LiDAR scan now: (beams,) float32 ranges (m, REP-117; :attr:`lidar`'s angles)."""
        return self.lidar.scan(*self._base_link_pose())

    def depth_cloud(self) -> np.ndarray:
        """One 3-D cast now: (m, 3) float32 points of the valid returns (m, depth_link)."""
        return self.depth.cloud(*self._base_link_pose())

    def _base_link_pose(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        com, com_quat = pybullet.getBasePositionAndOrientation(
            self.robot.body_id, physicsClientId=self.client
        )
        return self._link_pose(com, com_quat)

    # ------------------------------------------------------------------ camera

    def add_camera(self, config: CameraConfig | None = None) -> FollowCamera:
        """Create (or replace) the follow camera on the robot base and return it."""
        self._camera = FollowCamera(self.client, self.robot.body_id, config)
        return self._camera

    def render_frame(self) -> np.ndarray:
        """Render one camera frame now ((H, W, 3) uint8; creates a default camera if none)."""
        if self._camera is None:
            self.add_camera()
        assert self._camera is not None
        return self._camera.render(self.time)

    def record_every(self, steps: int, config: CameraConfig | None = None) -> None:
        """Render a frame every ``steps`` physics steps into a buffer (0 stops recording).

        Collect the frames with :meth:`take_frames`; writing the video is the caller's job.
        """
        if steps < 0:
            raise ValueError("steps must be >= 0")
        if steps and (config is not None or self._camera is None):
            self.add_camera(config)
        self._record_every = int(steps)

    def take_frames(self) -> list[np.ndarray]:
        """Return the frames recorded since the last call and clear the buffer."""
        frames, self._frames = self._frames, []
        return frames

    # ------------------------------------------------------------------ summary

    def summary(self, extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """Run summary as a JSON-ready dict (:func:`~.run_summary.run_summary`).

        ``extra`` entries (e.g. the node's pacing statistics) are merged in at top level.
        """
        pos, _ = self._link_pose(self.monitor.last_base_position, self.monitor.last_base_quaternion)
        return run_summary(self, pos, extra)

    def write_summary(
        self, path: str | os.PathLike[str], extra: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        """Write :meth:`summary` as JSON to ``path`` (directories created) and return it."""
        data = self.summary(extra)
        write_json(path, data)
        return data

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if not self._closed:
            self._closed = True
            try:
                pybullet.disconnect(self.client)
            except pybullet.error:
                pass

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
