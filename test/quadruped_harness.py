"""Minimal PyBullet harness for the quadruped controller tests and benchmark.

Flat plane, the A1 loaded by ``load_robot``, ``MotorDriver`` applying the joint commands at
every 1 kHz physics step, and the controller called every ``control_period``. This is not the
project's simulator (``safe_legged_c3bf.sim``): only what the controller tests need.
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
    """Samples taken at every controller tick."""

    t: list[float] = field(default_factory=list)
    position: list[np.ndarray] = field(default_factory=list)  # base_link origin, odom
    rpy: list[np.ndarray] = field(default_factory=list)
    velocity_body: list[np.ndarray] = field(default_factory=list)  # base_link linear
    omega_body: list[np.ndarray] = field(default_factory=list)  # base_link angular
    height_target: list[float] = field(default_factory=list)
    ground: list[float] = field(default_factory=list)
    command: list[np.ndarray] = field(default_factory=list)

    def arrays(self) -> dict[str, np.ndarray]:
        """Return every series as a numpy array."""
        return {k: np.asarray(v) for k, v in self.__dict__.items()}


class QuadrupedSim:
    """A1 on a plane in a DIRECT PyBullet client."""

    def __init__(self, yaw: float = 0.0) -> None:
        self.client = pybullet.connect(pybullet.DIRECT)
        pybullet.setGravity(0, 0, -9.81, physicsClientId=self.client)
        pybullet.setTimeStep(PHYSICS_DT, physicsClientId=self.client)
        pybullet.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=self.client)
        pybullet.loadURDF("plane.urdf", physicsClientId=self.client)
        self.robot = load_robot(self.client, "a1", (0.0, 0.0), yaw)
        self.driver = MotorDriver(self.client, self.robot)
        self.body = self.robot.body_id
        info = pybullet.getDynamicsInfo(self.body, -1, physicsClientId=self.client)
        self._inertial_offset = np.array(info[3])
        self.t = 0.0
        self.steps = 0
        self.controller_time = 0.0  # wall time spent inside controller.update (s)
        self.physics_time = 0.0  # wall time of driver + stepSimulation (s)
        self.controller_cpu = 0.0  # CPU time of this thread inside controller.update (s)
        self.physics_cpu = 0.0  # CPU time of driver + stepSimulation (s)
        self.wall_time = 0.0  # wall time of whole run() calls (s)

    def close(self) -> None:
        """Disconnect the client."""
        if self.client is not None:
            pybullet.disconnect(self.client)
            self.client = None

    def __enter__(self) -> QuadrupedSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def base_state(self) -> BaseState:
        """BaseState of base_link (PyBullet reports the base's centre of mass, in world axes)."""
        pos, orn = pybullet.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        lin, ang = pybullet.getBaseVelocity(self.body, physicsClientId=self.client)
        rot = np.array(pybullet.getMatrixFromQuaternion(orn)).reshape(3, 3)
        lever = rot @ self._inertial_offset
        origin = np.array(pos) - lever
        omega = np.array(ang)
        lx, ly, lz = lever
        v_origin = np.array(lin) - np.array(
            [
                omega[1] * lz - omega[2] * ly,
                omega[2] * lx - omega[0] * lz,
                omega[0] * ly - omega[1] * lx,
            ]
        )
        return BaseState(origin, np.array(orn), rot.T @ v_origin, rot.T @ omega, self.t)

    def joint_states(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities in the robot's joint order."""
        states = pybullet.getJointStates(
            self.body, self.robot.joint_indices, physicsClientId=self.client
        )
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def run(
        self,
        controller,
        command_fn: Callable[[float], VelocityCommand],
        duration: float,
        log: RunLog | None = None,
        abort_on_fall: bool = True,
    ) -> bool:
        """Simulate ``duration`` s; return False if the robot fell (and stop there)."""
        wall_start = time.perf_counter()
        try:
            return self._run(controller, command_fn, duration, log, abort_on_fall)
        finally:
            self.wall_time += time.perf_counter() - wall_start

    def _run(self, controller, command_fn, duration, log, abort_on_fall) -> bool:
        period_steps = max(1, int(round(controller.control_period / PHYSICS_DT)))
        n_steps = int(round(duration / PHYSICS_DT))
        for _ in range(n_steps):
            if self.steps % period_steps == 0:
                base = self.base_state()
                q, dq = self.joint_states()
                cmd = command_fn(self.t)
                t0, c0 = time.perf_counter(), time.thread_time()
                jc = controller.update(self.t, base, q, dq, cmd)
                self.controller_time += time.perf_counter() - t0
                self.controller_cpu += time.thread_time() - c0
                self.driver.set_command(jc, self.t)
                if log is not None:
                    log.t.append(self.t)
                    log.position.append(base.position)
                    log.rpy.append(base.rpy)
                    log.velocity_body.append(base.linear_velocity)
                    log.omega_body.append(base.angular_velocity)
                    log.height_target.append(
                        np.nan if controller.height_target is None else controller.height_target
                    )
                    log.ground.append(
                        np.nan if controller.ground_height is None else controller.ground_height
                    )
                    log.command.append(cmd.as_array())
                if abort_on_fall and fallen(base):
                    return False
            t0, c0 = time.perf_counter(), time.thread_time()
            self.driver.apply(self.t)
            pybullet.stepSimulation(physicsClientId=self.client)
            self.physics_time += time.perf_counter() - t0
            self.physics_cpu += time.thread_time() - c0
            self.steps += 1
            self.t = self.steps * PHYSICS_DT
        return not fallen(self.base_state())


def fallen(base: BaseState, min_height: float = 0.12, max_tilt: float = 0.6) -> bool:
    """True when the base is too low or roll/pitch exceed ``max_tilt`` rad."""
    roll, pitch, _ = base.rpy
    return bool(base.position[2] < min_height or abs(roll) > max_tilt or abs(pitch) > max_tilt)


def constant(vx: float = 0.0, vy: float = 0.0, vz: float = 0.0, yaw_rate: float = 0.0):
    """Command function returning the same command at all times."""
    cmd = VelocityCommand(vx, vy, vz, yaw_rate)
    return lambda t: cmd


def random_piecewise_commands(
    seed: int,
    duration: float,
    limits: tuple[float, float, float, float] = (1.0, 0.5, 0.3, 1.5),
    hold: tuple[float, float] = (1.0, 4.0),
    zero_probability: float = 0.15,
):
    """Random piecewise-constant commands, uniform within +-limits (vx, vy, vz, yaw_rate).

    Each command is held for a uniform random time in ``hold`` (s); with probability
    ``zero_probability`` the command is zero (the robot stops and stands).
    """
    rng = np.random.default_rng(seed)
    times, cmds = [0.0], []
    while times[-1] < duration:
        if rng.random() < zero_probability:
            cmds.append(VelocityCommand())
        else:
            vx, vy, vz, yaw_rate = (float(rng.uniform(-lim, lim)) for lim in limits)
            cmds.append(VelocityCommand(vx=vx, vy=vy, vz=vz, yaw_rate=yaw_rate))
        times.append(times[-1] + float(rng.uniform(*hold)))
    starts = np.array(times[:-1])

    def fn(t: float) -> VelocityCommand:
        return cmds[int(np.searchsorted(starts, t, side="right")) - 1]

    return fn


def window_mean(log: RunLog, series: str, t0: float, t1: float) -> np.ndarray:
    """Mean of a logged series over t in [t0, t1)."""
    data = log.arrays()
    mask = (data["t"] >= t0) & (data["t"] < t1)
    return data[series][mask].mean(axis=0)


# ---------------------------------------------------------------------- scenarios
# Shared by test_quadruped_sim.py and benchmarks/quadruped_tracking.py.

COMMAND_START = 0.5  # s: the robot first lands on its feet (spawned 2 cm above the ground)
SETTLE = 2.0  # s after the command starts
WINDOW = 5.0  # s of averaging after the settle

TRACKING_COMMANDS = {
    "vx": (VelocityCommand(vx=0.5), "velocity_body", 0, 0.5),
    "vy": (VelocityCommand(vy=0.2), "velocity_body", 1, 0.2),
    "yaw_rate": (VelocityCommand(yaw_rate=0.5), "omega_body", 2, 0.5),
}


@dataclass
class ScenarioResult:
    """Outcome of one simulated scenario."""

    name: str
    ok: bool
    sim_time: float
    wall_time: float
    controller_time: float
    controller_cpu: float
    physics_time: float
    physics_cpu: float
    mpc_solve_times: list[float]
    mpc_failures: int
    values: dict[str, float]


def _result(name: str, sim: QuadrupedSim, controller, ok: bool, values) -> ScenarioResult:
    return ScenarioResult(
        name=name,
        ok=ok,
        sim_time=sim.t,
        wall_time=sim.wall_time,
        controller_time=sim.controller_time,
        controller_cpu=sim.controller_cpu,
        physics_time=sim.physics_time,
        physics_cpu=sim.physics_cpu,
        mpc_solve_times=list(controller.mpc_solve_times),
        mpc_failures=controller.mpc_failures,
        values=values,
    )


def run_tracking(kind: str, controller) -> ScenarioResult:
    """Command vx, vy or yaw_rate from COMMAND_START; average the response over the window."""
    command, series, index, target = TRACKING_COMMANDS[kind]

    def fn(t: float) -> VelocityCommand:
        return command if t >= COMMAND_START else VelocityCommand()

    t0 = COMMAND_START + SETTLE
    log = RunLog()
    with QuadrupedSim() as sim:
        ok = sim.run(controller, fn, t0 + WINDOW, log)
        values = {"target": target}
        if ok:
            mean = window_mean(log, series, t0, t0 + WINDOW)
            values["measured"] = float(mean[index])
            values["relative_error"] = abs(values["measured"] - target) / target
            others = [i for i in range(3) if i != index]
            values["cross_axis_max"] = float(np.max(np.abs(mean[others])))
        return _result(kind, sim, controller, ok, values)


def height_reference(t: float, nominal: float, rate: float = 0.1) -> float:
    """Body height (m) commanded by :func:`height_command` integrated from ``nominal``."""
    down = min(max(t - 3.0, 0.0), 0.8)
    up = min(max(t - 5.0, 0.0), 0.8)
    return nominal - rate * down + rate * up


def height_command(t: float) -> VelocityCommand:
    """Walk at 0.3 m/s; vz = -0.1 m/s on [3, 3.8) s (0.08 m drop), +0.1 on [5, 5.8) s."""
    if t < COMMAND_START:
        return VelocityCommand()
    vz = -0.1 if 3.0 <= t < 3.8 else (0.1 if 5.0 <= t < 5.8 else 0.0)
    return VelocityCommand(vx=0.3, vz=vz)


def run_height(controller) -> ScenarioResult:
    """Drop the body 0.08 m and raise it back while walking; compare with the reference."""
    log = RunLog()
    nominal = controller.params.body_height
    t_end = COMMAND_START + SETTLE + WINDOW
    with QuadrupedSim() as sim:
        ok = sim.run(controller, height_command, t_end, log)
        values = {}
        if ok:
            d = log.arrays()
            mask = d["t"] >= COMMAND_START + SETTLE
            ref = np.array([height_reference(t, nominal) for t in d["t"][mask]])
            height = d["position"][mask, 2]  # flat ground at z = 0
            err = height - ref
            low = (d["t"] >= 4.0) & (d["t"] < 5.0)
            values = {
                "max_abs_error": float(np.max(np.abs(err))),
                "mean_abs_error": float(np.mean(np.abs(err))),
                "lowest_mean": float(d["position"][low, 2].mean()),
                "forward_speed": float(d["velocity_body"][mask, 0].mean()),
            }
        return _result("height", sim, controller, ok, values)


def run_random(seed: int, duration: float, controller) -> ScenarioResult:
    """Random piecewise-constant commands within the controller's limits for ``duration``."""
    p = controller.params
    limits = (p.max_forward_speed, p.max_lateral_speed, p.max_vertical_speed, p.max_yaw_rate)
    log = RunLog()
    with QuadrupedSim() as sim:
        ok = sim.run(controller, random_piecewise_commands(seed, duration, limits), duration, log)
        d = log.arrays()
        values = {
            "max_abs_roll": float(np.max(np.abs(d["rpy"][:, 0]))),
            "max_abs_pitch": float(np.max(np.abs(d["rpy"][:, 1]))),
            "min_height": float(np.min(d["position"][:, 2])),
            "distance": float(
                np.sum(np.linalg.norm(np.diff(d["position"][:, :2], axis=0), axis=1))
            ),
        }
        return _result(f"random seed {seed}", sim, controller, ok, values)
