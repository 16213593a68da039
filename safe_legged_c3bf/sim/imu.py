"""The simulated IMU's accelerometer: specific force of base_link, in base_link.

f = R^T (a + g e_z) (m/s^2), R the orientation of base_link in odom (= world), a the
world-frame acceleration of the base_link origin and g the scenario's gravity (m/s^2,
positive; gravity points along -z). a is the finite difference of the world-frame velocity
between two consecutive readings (zero at the first). Plain floats: this runs at the state
rate, where numpy's per-call overhead for 3-vectors costs more than the math.
"""

from __future__ import annotations

from collections.abc import Sequence

from safe_legged_c3bf.interfaces.rotations import rotate, rotate_inverse


class Accelerometer:
    """Specific force from successive base states (see the module docstring)."""

    def __init__(self, gravity: float) -> None:
        """``gravity``: magnitude of the gravitational acceleration (m/s^2)."""
        self._gravity = gravity
        self._last: tuple[float, tuple[float, float, float]] | None = None

    def specific_force(
        self, t: float, orientation: Sequence[float], velocity: Sequence[float]
    ) -> tuple[float, float, float]:
        """Specific force (m/s^2, base_link) at sim time ``t`` (s).

        ``orientation``: quaternion (x, y, z, w) of base_link in odom; ``velocity``: linear
        velocity of the base_link origin (m/s, base_link).
        """
        vx, vy, vz = rotate(orientation, velocity)
        ax = ay = az = 0.0
        last = self._last
        if last is not None and t > last[0]:
            t0, (ux, uy, uz) = last
            ax, ay, az = (vx - ux) / (t - t0), (vy - uy) / (t - t0), (vz - uz) / (t - t0)
        self._last = (t, (vx, vy, vz))
        return rotate_inverse(orientation, (ax, ay, az + self._gravity))
