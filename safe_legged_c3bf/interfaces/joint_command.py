"""Joint-level motor command: what a gait controller sends to the robot's motor drivers.

Per joint the driver applies tau = kp (q - q_meas) + kd (dq - dq_meas) + tau_ff, in N m,
with q in rad and dq in rad/s, exactly as the ``MotorCommand`` message carries it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class JointCommand:
    """A motor command for a set of named joints (arrays of equal length, SI units).

    Attributes:
        names: joint names, matching the robot's joint names.
        q: target positions (rad).
        dq: target velocities (rad/s).
        kp: position gains (N m / rad).
        kd: velocity gains (N m s / rad).
        tau: feed-forward torques (N m).

    """

    names: list[str]
    q: np.ndarray
    dq: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    tau: np.ndarray

    def __post_init__(self) -> None:
        self.names = list(self.names)
        n = len(self.names)
        for field in ("q", "dq", "kp", "kd", "tau"):
            value = np.asarray(getattr(self, field), dtype=float).reshape(-1)
            if value.size == 1 and n != 1:
                value = np.full(n, float(value[0]))
            if value.size != n:
                raise ValueError(f"JointCommand.{field} has {value.size} entries for {n} joints")
            setattr(self, field, value)

    def is_finite(self) -> bool:
        """Return True when every number in the command is finite."""
        return all(
            bool(np.all(np.isfinite(getattr(self, f)))) for f in ("q", "dq", "kp", "kd", "tau")
        )

    @classmethod
    def zeros(cls, names: list[str]) -> JointCommand:
        """Return an all-zero (limp) command for the given joints."""
        n = len(names)
        z = np.zeros(n)
        return cls(list(names), z, z.copy(), z.copy(), z.copy(), z.copy())
