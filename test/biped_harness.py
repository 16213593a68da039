"""Minimal PyBullet harness for the biped tests and benchmark (not the project's world module).

A flat plane, the biped from ``sim.robots.load_robot``, the emulated ``MotorDriver`` at every
1 kHz physics step and a gait controller called every ``control_period``. Ground-truth base
state stands in for odometry.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pybullet
import pybullet_data

from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.sim.motor_driver import MotorDriver
from safe_legged_c3bf.sim.robots import load_robot

PHYSICS_DT = 0.001


@dataclass
class RunLog:
    """What a run recorded (one row per controller tick)."""

    t: list = field(default_factory=list)
    position: list = field(default_factory=list)
    rpy: list = field(default_factory=list)
    velocity_body: list = field(default_factory=list)
    yaw_rate: list = field(default_factory=list)
    command: list = field(default_factory=list)
    fell: bool = False
    fall_time: float | None = None
    #: CPU time (thread_time, s) spent in controller.update and in driver + physics stepping;
    #: CPU rather than wall time so that other processes on the machine do not inflate it.
    controller_seconds: float = 0.0
    physics_seconds: float = 0.0
    sim_seconds: float = 0.0

    def arrays(self) -> dict:
        """Return the logged lists as numpy arrays."""
        return {
            "t": np.array(self.t),
            "position": np.array(self.position),
            "rpy": np.array(self.rpy),
            "velocity_body": np.array(self.velocity_body),
            "yaw_rate": np.array(self.yaw_rate),
            "command": np.array(self.command),
        }


class BipedSim:
    """Plane + biped + motor drivers in a DIRECT PyBullet client."""

    def __init__(self, gui: bool = False, lateral_friction: float = 1.0) -> None:
        self.client = pybullet.connect(pybullet.GUI if gui else pybullet.DIRECT)
        pybullet.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=self.client)
        pybullet.setGravity(0, 0, -9.81, physicsClientId=self.client)
        pybullet.setTimeStep(PHYSICS_DT, physicsClientId=self.client)
        self.plane = pybullet.loadURDF("plane.urdf", physicsClientId=self.client)
        pybullet.changeDynamics(
            self.plane, -1, lateralFriction=lateral_friction, physicsClientId=self.client
        )
        self.robot = load_robot(self.client, "biped")
        self.driver = MotorDriver(self.client, self.robot)
        self.t = 0.0

    def close(self) -> None:
        """Disconnect the client."""
        pybullet.disconnect(self.client)

    def base_state(self) -> BaseState:
        """Ground-truth base state (odom == world)."""
        body, c = self.robot.body_id, self.client
        pos, quat = pybullet.getBasePositionAndOrientation(body, physicsClientId=c)
        lin, ang = pybullet.getBaseVelocity(body, physicsClientId=c)
        rot = np.array(pybullet.getMatrixFromQuaternion(quat)).reshape(3, 3)
        return BaseState(pos, quat, rot.T @ np.array(lin), rot.T @ np.array(ang), self.t)

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Measured joint positions and velocities, in ``robot.joint_names`` order."""
        states = pybullet.getJointStates(
            self.robot.body_id, self.robot.joint_indices, physicsClientId=self.client
        )
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def run(
        self,
        controller,
        duration: float,
        command_fn: Callable[[float], VelocityCommand],
        fall_height: float = 0.45,
        push: Callable[[float], np.ndarray | None] | None = None,
    ) -> RunLog:
        """Run ``controller`` for ``duration`` s of sim time; stop early on a fall.

        ``command_fn(t)`` gives the velocity command; ``push(t)`` may return a world-frame
        force (N) applied at the torso origin during that physics step.
        """
        log = RunLog()
        n_ctrl = max(1, int(round(controller.control_period / PHYSICS_DT)))
        steps = int(round(duration / PHYSICS_DT))
        joint_index = np.array([self.robot.joint_names.index(n) for n in controller.joint_names])
        for k in range(steps):
            if k % n_ctrl == 0:
                base = self.base_state()
                q, dq = self.joint_state()
                cmd = command_fn(self.t)
                w0 = time.thread_time()
                jc = controller.update(self.t, base, q[joint_index], dq[joint_index], cmd)
                log.controller_seconds += time.thread_time() - w0
                self.driver.set_command(jc, self.t)
                rpy = base.rpy
                log.t.append(self.t)
                log.position.append(base.position.copy())
                log.rpy.append(rpy)
                log.velocity_body.append(base.linear_velocity.copy())
                log.yaw_rate.append(base.angular_velocity_world[2])
                log.command.append(cmd.as_array())
                if base.position[2] < fall_height or abs(rpy[0]) > 0.8 or abs(rpy[1]) > 0.8:
                    log.fell = True
                    log.fall_time = self.t
                    break
            w0 = time.thread_time()
            self.driver.apply(self.t)
            if push is not None:
                force = push(self.t)
                if force is not None:
                    pybullet.applyExternalForce(
                        self.robot.body_id,
                        -1,
                        list(force),
                        [0, 0, 0],
                        pybullet.LINK_FRAME,
                        physicsClientId=self.client,
                    )
            pybullet.stepSimulation(physicsClientId=self.client)
            log.physics_seconds += time.thread_time() - w0
            self.t += PHYSICS_DT
        log.sim_seconds = self.t
        return log


def constant(vx: float = 0.0, vy: float = 0.0, yaw_rate: float = 0.0, start: float = 0.0):
    """Command function: zero before ``start``, then the given constant command."""

    def fn(t: float) -> VelocityCommand:
        if t < start:
            return VelocityCommand()
        return VelocityCommand(vx=vx, vy=vy, yaw_rate=yaw_rate)

    return fn


def stop_and_go(period: float, duty: float, start: float = 0.0, **command):
    """Command function: ``command`` for ``duty`` of every ``period`` s from ``start``, else zero.

    A safety filter holding and releasing the robot; ``command`` holds VelocityCommand fields.
    """

    def fn(t: float) -> VelocityCommand:
        if t < start or ((t - start) / period) % 1.0 >= duty:
            return VelocityCommand()
        return VelocityCommand(**command)

    return fn


def random_piecewise(seed: int, limits, hold=(2.0, 6.0), start: float = 1.0):
    """Command function: random piecewise-constant commands inside ``limits``.

    ``limits`` has attributes vx_min, vx_max, vy_max, yaw_rate_max. Each segment lasts a random
    time in ``hold``; about one segment in five is a zero (stop) command.
    """
    rng = np.random.default_rng(seed)
    times, cmds = [start], []
    for _ in range(200):
        if rng.random() < 0.2:
            cmds.append(VelocityCommand())
        else:
            cmds.append(
                VelocityCommand(
                    vx=float(rng.uniform(limits.vx_min, limits.vx_max)),
                    vy=float(rng.uniform(-limits.vy_max, limits.vy_max)),
                    yaw_rate=float(rng.uniform(-limits.yaw_rate_max, limits.yaw_rate_max)),
                )
            )
        times.append(times[-1] + float(rng.uniform(*hold)))

    def fn(t: float) -> VelocityCommand:
        if t < start:
            return VelocityCommand()
        i = int(np.searchsorted(times, t, side="right")) - 1
        return cmds[min(i, len(cmds) - 1)]

    fn.segments = list(zip(times, cmds, strict=False))
    return fn
