"""Parameters of the quadruped (A1) convex-MPC gait controller, with defaults and checks.

Every field has a default that matches ``config/quadruped_controller.yaml``. Units are SI
(m, s, kg, N, rad). :meth:`QuadrupedParams.validate` raises ``ValueError`` naming the first
bad parameter. The mass, inertia and centre-of-mass offset are those of the A1 model of
``pybullet_data`` as PyBullet simulates it (PyBullet derives link inertias from the collision
shapes), lumped into one rigid body in the standing posture; ``test_quadruped_kinematics``
recomputes them from PyBullet.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, NoReturn

# Composite rigid-body inertia (kg m^2) about the centre of mass, base_link axes, standing
# posture, as PyBullet simulates the pybullet_data A1 (row-major 3x3).
A1_INERTIA = (
    0.1454, 0.0, -0.0142,
    0.0, 0.3586, 0.0,
    -0.0142, 0.0, 0.3868,
)  # fmt: skip

#: parameters that must be finite numbers > 0
_POSITIVE_FIELDS = (
    "control_period", "mpc_dt", "mpc_period", "mass", "friction_coefficient",
    "max_normal_force", "gait_period", "stand_delay", "swing_height", "foot_radius",
    "body_height", "min_body_height", "max_body_height", "max_forward_speed",
    "max_lateral_speed", "max_yaw_rate", "max_vertical_speed",
    "max_linear_acceleration", "max_yaw_acceleration", "osqp_eps_abs", "osqp_eps_rel",
)  # fmt: skip
#: parameters that must be finite numbers >= 0
_NON_NEGATIVE_FIELDS = (
    "min_normal_force", "foothold_velocity_gain", "max_foothold_offset", "weight_force",
    "swing_kp", "swing_kd", "stance_kp", "stance_kd", "fault_damping_kd",
    "velocity_integral_gain", "yaw_rate_integral_gain", "max_velocity_correction",
    "max_yaw_rate_correction", "height_integral_gain", "max_height_correction",
)  # fmt: skip
#: the MPC state weights, three numbers each
_WEIGHT_FIELDS = (
    "weight_orientation",
    "weight_position",
    "weight_angular_velocity",
    "weight_linear_velocity",
)


@dataclass
class QuadrupedParams:
    """Tunable parameters of the A1 trot controller (``QuadrupedMpcController``).

    Timing:
        control_period: period of :meth:`update` (s).
        mpc_dt: time step of the MPC prediction model (s).
        mpc_horizon: number of MPC steps.
        mpc_period: time between two MPC solves (s); a solve also happens at contact changes.

    Body model:
        mass: total mass (kg).
        inertia: body inertia about the centre of mass in base_link axes, row-major (kg m^2).
        com_offset: centre of mass in base_link (m).

    Contact forces:
        friction_coefficient: friction coefficient assumed by the MPC (pyramid cone).
        max_normal_force: upper bound of a stance foot's normal force (N).
        min_normal_force: lower bound of a stance foot's normal force (N).

    MPC weights (diagonal of the state cost; state = roll, pitch, yaw, position, angular
    velocity, linear velocity, all in odom axes):
        weight_orientation, weight_position, weight_angular_velocity, weight_linear_velocity:
            three weights each.
        weight_force: weight of the squared forces (1/N^2).

    Gait:
        gait_period: duration of one trot cycle (s).
        duty_factor: fraction of the cycle a leg is in stance.
        stand_delay: time the planar command must be zero before the robot stops and stands (s).
        swing_height: apex height of a swing foot above its lift-off / touch-down line (m).
        foothold_velocity_gain: Raibert velocity-feedback gain of the foothold (s).
        max_foothold_offset: bound of the foothold's horizontal offset from the hip (m).
        foot_radius: radius of the foot sphere (m).

    Body height (base_link above the ground):
        body_height: nominal height (m).
        min_body_height: lowest height the vz command may lead to (m).
        max_body_height: highest height the vz command may lead to (m).

    Command limits:
        max_forward_speed, max_lateral_speed (m/s), max_yaw_rate (rad/s),
        max_vertical_speed (m/s): commands are clipped to these.
        max_linear_acceleration (m/s^2), max_yaw_acceleration (rad/s^2): the commanded
            velocity is rate-limited to these (smooth start and stop).

    Integral action (removes steady-state tracking errors of the lumped model):
        velocity_integral_gain (1/s), yaw_rate_integral_gain (1/s): integral gains on the
            heading-frame velocity and yaw-rate errors while trotting with a settled command.
        max_velocity_correction (m/s), max_yaw_rate_correction (rad/s): their bounds.
        height_integral_gain (1/s): integral gain on the body-height error.
        max_height_correction (m): its bound.

    Joint gains:
        swing_kp, swing_kd: joint PD gains of swing legs (N m/rad, N m s/rad).
        stance_kp, stance_kd: joint PD gains of stance legs for posture (small).
        fault_damping_kd: joint damping (N m s/rad) commanded when the measured state is
            not finite.

    Solver:
        osqp_eps_abs, osqp_eps_rel: OSQP tolerances.
        osqp_max_iter: OSQP iteration limit.

    """

    control_period: float = 0.004
    mpc_dt: float = 0.03
    mpc_horizon: int = 10
    mpc_period: float = 0.015

    mass: float = 12.458
    inertia: tuple[float, ...] = A1_INERTIA
    com_offset: tuple[float, float, float] = (-0.0056, 0.0008, -0.0218)

    friction_coefficient: float = 0.4
    max_normal_force: float = 160.0
    min_normal_force: float = 2.0

    weight_orientation: tuple[float, float, float] = (25.0, 25.0, 10.0)
    weight_position: tuple[float, float, float] = (1.0, 1.0, 50.0)
    weight_angular_velocity: tuple[float, float, float] = (0.5, 0.5, 1.0)
    weight_linear_velocity: tuple[float, float, float] = (4.0, 4.0, 2.0)
    weight_force: float = 1e-5

    gait_period: float = 0.3
    duty_factor: float = 0.5
    stand_delay: float = 0.3
    swing_height: float = 0.08
    foothold_velocity_gain: float = 0.17
    max_foothold_offset: float = 0.15
    foot_radius: float = 0.02

    body_height: float = 0.28
    min_body_height: float = 0.18
    max_body_height: float = 0.28

    max_forward_speed: float = 1.0
    max_lateral_speed: float = 0.5
    max_yaw_rate: float = 1.5
    max_vertical_speed: float = 0.3
    max_linear_acceleration: float = 2.0
    max_yaw_acceleration: float = 4.0

    velocity_integral_gain: float = 1.5
    yaw_rate_integral_gain: float = 1.5
    max_velocity_correction: float = 0.2
    max_yaw_rate_correction: float = 0.3
    height_integral_gain: float = 2.0
    max_height_correction: float = 0.03

    swing_kp: float = 40.0
    swing_kd: float = 1.5
    stance_kp: float = 0.0
    stance_kd: float = 1.0
    fault_damping_kd: float = 2.0

    osqp_eps_abs: float = 1e-3
    osqp_eps_rel: float = 1e-3
    osqp_max_iter: int = 200

    def __post_init__(self) -> None:
        self.inertia = tuple(float(v) for v in self.inertia)
        self.com_offset = tuple(float(v) for v in self.com_offset)  # type: ignore[assignment]
        for name in _WEIGHT_FIELDS:
            setattr(self, name, tuple(float(v) for v in getattr(self, name)))
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first parameter that is out of range.

        The groups are checked in this order: number types and signs, timing and gait
        timing, contact forces, body model (inertia, centre of mass), MPC weights, body
        height and leg geometry.
        """
        self._validate_types()
        self._validate_timing()
        self._validate_contact_forces()
        self._validate_body_model()
        self._validate_weights()
        self._validate_geometry()

    def _reject(self, name: str, why: str) -> NoReturn:
        """Raise the ``ValueError`` that names parameter ``name``, its value and ``why``."""
        raise ValueError(f"quadruped parameter '{name}' = {getattr(self, name)!r}: {why}")

    def _validate_types(self) -> None:
        """Positive numbers, non-negative numbers and integers >= 1."""
        for name in _POSITIVE_FIELDS:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                self._reject(name, "must be a finite number > 0")
        for name in _NON_NEGATIVE_FIELDS:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                self._reject(name, "must be a finite number >= 0")
        for name in ("mpc_horizon", "osqp_max_iter"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                self._reject(name, "must be an integer >= 1")

    def _validate_timing(self) -> None:
        """MPC horizon and periods, control period, duty factor and swing duration."""
        if self.mpc_horizon > 40:
            self._reject("mpc_horizon", "must be <= 40 (solve time)")
        if self.mpc_period < self.control_period:
            self._reject("mpc_period", "must be >= control_period")
        if self.control_period > 0.01:
            self._reject("control_period", "must be <= 0.01 s for stable torque control")
        if not 0.5 <= self.duty_factor < 1.0:
            self._reject("duty_factor", "must be in [0.5, 1) (a trot without flight phase)")
        if self.gait_period * (1.0 - self.duty_factor) < 2 * self.control_period:
            self._reject("gait_period", "swing phase shorter than two control periods")

    def _validate_contact_forces(self) -> None:
        """Normal-force bounds and friction coefficient."""
        if self.min_normal_force >= self.max_normal_force:
            self._reject("min_normal_force", "must be < max_normal_force")
        if self.friction_coefficient > 2.0:
            self._reject("friction_coefficient", "must be <= 2")

    def _validate_body_model(self) -> None:
        """Inertia (9 finite numbers, symmetric, positive definite) and centre of mass."""
        if len(self.inertia) != 9 or not all(math.isfinite(v) for v in self.inertia):
            self._reject("inertia", "must be 9 finite numbers (row-major 3x3)")
        i = self.inertia
        if any(abs(i[r * 3 + c] - i[c * 3 + r]) > 1e-9 for r in range(3) for c in range(3)):
            self._reject("inertia", "must be symmetric")
        # positive definiteness (Sylvester)
        d1 = i[0]
        d2 = i[0] * i[4] - i[1] * i[3]
        d3 = (
            i[0] * (i[4] * i[8] - i[5] * i[7])
            - i[1] * (i[3] * i[8] - i[5] * i[6])
            + i[2] * (i[3] * i[7] - i[4] * i[6])
        )
        if not (d1 > 0 and d2 > 0 and d3 > 0):
            self._reject("inertia", "must be positive definite")
        if len(self.com_offset) != 3 or not all(math.isfinite(v) for v in self.com_offset):
            self._reject("com_offset", "must be 3 finite numbers")
        if any(abs(v) > 0.1 for v in self.com_offset):
            self._reject("com_offset", "must be within 0.1 m of base_link")

    def _validate_weights(self) -> None:
        """The four MPC state-weight triples."""
        for name in _WEIGHT_FIELDS:
            value = getattr(self, name)
            if len(value) != 3 or not all(math.isfinite(v) and v >= 0 for v in value):
                self._reject(name, "must be 3 finite numbers >= 0")

    def _validate_geometry(self) -> None:
        """Body-height range, swing height and foothold offset within the A1's reach."""
        if not self.min_body_height <= self.body_height <= self.max_body_height:
            self._reject("body_height", "must lie in [min_body_height, max_body_height]")
        if self.max_body_height > 0.34:
            self._reject("max_body_height", "must be <= 0.34 m (leg reach of the A1)")
        if self.min_body_height < 0.12:
            self._reject("min_body_height", "must be >= 0.12 m (knee limit of the A1)")
        if self.swing_height > 0.15:
            self._reject("swing_height", "must be <= 0.15 m")
        if self.max_foothold_offset > 0.3:
            self._reject("max_foothold_offset", "must be <= 0.3 m")

    def to_dict(self) -> dict[str, Any]:
        """Return the parameters as a flat dict (tuples as lists), as in the YAML file."""
        out = asdict(self)
        return {k: list(v) if isinstance(v, tuple) else v for k, v in out.items()}

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> QuadrupedParams:
        """Build parameters from a flat dict; unknown keys raise ``ValueError``.

        Also accepts a ROS 2 parameter file's content (``{node: {ros__parameters: {...}}}``).
        """
        values = _unwrap_ros_parameters(values)
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise ValueError(f"unknown quadruped parameter(s): {', '.join(unknown)}")
        kwargs: dict[str, Any] = {}
        for key, value in values.items():
            default = getattr(cls, key, None)
            if (
                isinstance(default, float)
                and isinstance(value, int)
                and not isinstance(value, bool)
            ):
                value = float(value)
            kwargs[key] = value
        return cls(**kwargs)

    @classmethod
    def from_yaml(cls, path: str) -> QuadrupedParams:
        """Load parameters from a YAML file (flat, or a ROS 2 parameter file).

        A relative path that does not exist is looked up in the package's config directory.
        """
        from safe_legged_c3bf.run.config import load_yaml

        return cls.from_dict(load_yaml(path))


def _unwrap_ros_parameters(values: dict[str, Any]) -> dict[str, Any]:
    """Return the ``ros__parameters`` mapping of a ROS 2 parameter file, or ``values``."""
    if "ros__parameters" in values:
        return dict(values["ros__parameters"])
    if len(values) == 1:
        (inner,) = values.values()
        if isinstance(inner, dict) and "ros__parameters" in inner:
            return dict(inner["ros__parameters"])
    return dict(values)
