"""Emulated joint motor drivers, as on real legged robots.

At every physics step each driver applies tau = kp (q* - q) + kd (dq* - dq) + tau_ff,
clipped to the joint's torque limit (N m), in PyBullet torque mode. When commands stop
arriving for longer than ``timeout`` the drivers fall back to a damping mode
(tau = -kd_damping dq), as real drivers do, and report it through :attr:`mode`.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence

import numpy as np
import pybullet

from safe_legged_c3bf.interfaces.joint_command import JointCommand
from safe_legged_c3bf.sim.robots import RobotHandle


class DriverMode(enum.Enum):
    """State of the motor drivers."""

    WAITING = "waiting"  # no command received yet: damping
    ACTIVE = "active"  # following the latest command
    DAMPING = "damping"  # commands timed out: damping


class MotorDriver:
    """PD + feed-forward torque drivers for all actuated joints of one robot."""

    def __init__(
        self,
        client: int,
        robot: RobotHandle,
        timeout: float = 0.1,
        damping_kd: float = 1.0,
    ) -> None:
        """Create drivers for ``robot``.

        Args:
            client: PyBullet physics client id.
            robot: the loaded robot.
            timeout: seconds (sim time) without a command before damping mode.
            damping_kd: damping gain in damping mode (N m s / rad).

        """
        if timeout <= 0 or damping_kd < 0:
            raise ValueError("motor driver timeout must be > 0 and damping_kd >= 0")
        self._client = client
        self._robot = robot
        self._index_of = {name: i for i, name in enumerate(robot.joint_names)}
        self._names = list(robot.joint_names)
        n = len(robot.joint_names)
        self.timeout = float(timeout)
        self.damping_kd = float(damping_kd)
        self._last_command_time: float | None = None
        self._limits = robot.torque_limits.tolist()
        self._indices = robot.joint_indices.tolist()
        #: The command in force, per joint in robot order, as plain floats: kp, q, kd, dq, tau.
        self._gains: tuple[list[float], ...] = tuple([0.0] * n for _ in range(5))
        self.mode = DriverMode.WAITING
        self.rejected_commands = 0
        self.last_torques = np.zeros(n)

    def set_command(self, command: JointCommand, now: float) -> bool:
        """Take a new command received at sim time ``now``; return False if rejected.

        Commands with non-finite numbers, unknown joint names or negative gains are rejected
        and counted; the previous command stays in force until it times out.
        """
        return self.set_targets(
            command.names, command.q.tolist(), command.dq.tolist(), command.kp.tolist(),
            command.kd.tolist(), command.tau.tolist(), now,
        )

    def set_targets(
        self,
        names: Sequence[str],
        q: list[float],
        dq: list[float],
        kp: list[float],
        kd: list[float],
        tau: list[float],
        now: float,
    ) -> bool:
        """Like :meth:`set_command` from float lists, each as long as ``names``.

        The fast path for the ROS bridge (a command per state period): plain Python on
        a dozen numbers is several times faster than building a :class:`JointCommand`.

        Raises:
            ValueError: when a list is not as long as ``names``.

        """
        n = len(names)
        if any(len(v) != n for v in (q, dq, kp, kd, tau)):
            raise ValueError(f"motor command lists must have {n} entries, one per joint")
        isfinite = math.isfinite
        if not (
            all(map(isfinite, q)) and all(map(isfinite, dq)) and all(map(isfinite, kp))
            and all(map(isfinite, kd)) and all(map(isfinite, tau))
        ) or any(v < 0.0 for v in kp) or any(v < 0.0 for v in kd):
            self.rejected_commands += 1
            return False
        if list(names) == self._names:  # every joint, in order: the usual case
            self._gains = (list(kp), list(q), list(kd), list(dq), list(tau))
        else:
            try:
                idx = [self._index_of[name] for name in names]
            except KeyError:
                self.rejected_commands += 1
                return False
            gains = tuple(list(g) for g in self._gains)
            for column, values in zip(gains, (kp, q, kd, dq, tau), strict=True):
                for i, v in zip(idx, values, strict=True):
                    column[i] = v
            self._gains = gains
        self._last_command_time = now
        return True

    def _update_mode(self, now: float) -> DriverMode:
        if self._last_command_time is None:
            self.mode = DriverMode.WAITING
        elif now - self._last_command_time > self.timeout:
            self.mode = DriverMode.DAMPING
        else:
            self.mode = DriverMode.ACTIVE
        return self.mode

    def compute_torques(self, q: np.ndarray, dq: np.ndarray, now: float) -> np.ndarray:
        """Torques (N m) the drivers apply given measured joint positions and velocities."""
        if self._update_mode(now) is DriverMode.ACTIVE:
            kp, q_ref, kd, dq_ref, tau_ff = (np.array(g) for g in self._gains)
            tau = kp * (q_ref - q) + kd * (dq_ref - dq) + tau_ff
        else:
            tau = -self.damping_kd * dq
        limits = self._robot.torque_limits
        return np.minimum(np.maximum(tau, -limits), limits)

    def apply(self, now: float) -> np.ndarray:
        """Read the joints, compute and apply torques for the next physics step.

        Same arithmetic as :meth:`compute_torques`, on plain floats: for a dozen joints that
        is several times faster than numpy, and this runs at every physics step.
        """
        states = pybullet.getJointStates(
            self._robot.body_id, self._indices, physicsClientId=self._client
        )
        limits = self._limits
        tau = []
        if self._update_mode(now) is DriverMode.ACTIVE:
            for s, kp, q, kd, dq, ff, lim in zip(states, *self._gains, limits, strict=True):
                t = kp * (q - s[0]) + kd * (dq - s[1]) + ff
                tau.append(lim if t > lim else -lim if t < -lim else t)
        else:
            kd = self.damping_kd
            for s, lim in zip(states, limits, strict=True):
                t = -kd * s[1]
                tau.append(lim if t > lim else -lim if t < -lim else t)
        pybullet.setJointMotorControlArray(
            self._robot.body_id,
            self._indices,
            pybullet.TORQUE_CONTROL,
            forces=tau,
            physicsClientId=self._client,
        )
        self.last_torques = np.array(tau)
        return self.last_torques
