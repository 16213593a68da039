"""Leg kinematics of the Unitree A1 (pybullet_data model) in the base_link frame.

Each leg is hip abduction (about x), thigh (about y) and calf (about y). The numbers are
those of ``pybullet_data/a1/a1.urdf``:

* hip joint at (+-0.183, +-0.047, 0) from base_link (front/rear, left/right);
* thigh joint at (0, +-0.08505, 0) from the hip joint, in the hip frame (left +, right -);
* calf joint at (0, 0, -0.2) from the thigh joint; foot (toe sphere centre, radius 0.02)
  at (0, 0, -0.2) from the calf joint.

Foot positions are those of the toe sphere centre. All functions work on the four legs at
once, in the order FR, FL, RR, RL, with joint vectors laid out as the 12 actuated joints
(hip, thigh, calf per leg).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

#: leg names, in the order used everywhere in this package
LEG_NAMES = ("FR", "FL", "RR", "RL")
#: the 12 actuated joints in the order of the A1 URDF (and PyBullet)
JOINT_NAMES = [f"{leg}_{j}_joint" for leg in LEG_NAMES for j in ("hip", "upper", "lower")]

HIP_X = 0.183
HIP_Y = 0.047
HIP_OFFSET = 0.08505  # thigh joint lateral offset from the abduction axis
THIGH_LENGTH = 0.2
CALF_LENGTH = 0.2
FOOT_RADIUS = 0.02

#: hip joint positions in base_link, (4, 3)
HIP_POSITIONS = np.array(
    [[HIP_X, -HIP_Y, 0.0], [HIP_X, HIP_Y, 0.0], [-HIP_X, -HIP_Y, 0.0], [-HIP_X, HIP_Y, 0.0]]
)
#: +1 for left legs, -1 for right legs
SIDE_SIGN = np.array([-1.0, 1.0, -1.0, 1.0])

_SIDE_OFFSET_LIST = (SIDE_SIGN * HIP_OFFSET).tolist()
_HIP_LIST = HIP_POSITIONS.tolist()
_EYE3 = np.eye(3)

#: joint limits (rad), per joint of a leg: hip, thigh, calf
JOINT_LOWER = np.tile([-0.802851455917, -1.0471975512, -2.69653369433], 4)
JOINT_UPPER = np.tile([0.802851455917, 4.18879020479, -0.916297857297], 4)

# link inertial data of the URDF (kg, m in the link frames); the toe is lumped with the calf
HIP_MASS = 0.696
THIGH_MASS = 1.013
THIGH_COM = (-0.003237, 0.022327, -0.027326)  # right legs; y flips sign on the left
CALF_MASS = 0.166 + 0.06
CALF_COM = (
    0.166 * 0.006435 / CALF_MASS,
    0.0,
    (0.166 * -0.107388 + 0.06 * -CALF_LENGTH) / CALF_MASS,
)
#: hip link centres of mass in the hip frames (front legs -x, rear +x; y outward)
HIP_COM_LIST = [
    (-0.003311, -0.000635, 3.1e-05),
    (-0.003311, 0.000635, 3.1e-05),
    (0.003311, -0.000635, 3.1e-05),
    (0.003311, 0.000635, 3.1e-05),
]
SIDE_SIGN_LIST = SIDE_SIGN.tolist()

_LOWER_LIST = JOINT_LOWER[:3].tolist()
_UPPER_LIST = JOINT_UPPER[:3].tolist()
_MAX_REACH = (THIGH_LENGTH + CALF_LENGTH) * 0.9999

#: standing posture of the simulator's ``load_robot`` (rad)
STANDING_POSE = np.tile([0.0, 0.8, -1.6], 4)


def nominal_foot_positions(height: float, foot_radius: float = FOOT_RADIUS) -> np.ndarray:
    """Foot centres (4, 3) in base_link for a level body ``height`` m above flat ground.

    The feet lie below the thigh joints (hip plus the lateral thigh offset).
    """
    feet = HIP_POSITIONS.copy()
    feet[:, 1] += SIDE_SIGN * HIP_OFFSET
    feet[:, 2] = -(height - foot_radius)
    return feet


def leg_kinematics(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Foot positions (4, 3) and foot Jacobians (4, 3, 3) in base_link for joint angles ``q``.

    ``jac[i]`` maps leg ``i``'s joint velocities (hip, thigh, calf) to its foot velocity
    relative to base_link, expressed in base_link. (Scalar code: for four legs it is several
    times faster than numpy's per-call overhead.)
    """
    qs = np.asarray(q, dtype=float).reshape(12).tolist()
    feet: list[float] = []
    jac: list[float] = []
    for leg in range(4):
        q0, q1, q2 = qs[3 * leg : 3 * leg + 3]
        q12 = q1 + q2
        s1, c1, s12, c12 = math.sin(q1), math.cos(q1), math.sin(q12), math.cos(q12)
        s0, c0 = math.sin(q0), math.cos(q0)
        x = -THIGH_LENGTH * s1 - CALF_LENGTH * s12
        z = -THIGH_LENGTH * c1 - CALF_LENGTH * c12
        y = _SIDE_OFFSET_LIST[leg]
        dx2 = -CALF_LENGTH * c12
        dz2 = CALF_LENGTH * s12
        dz1 = THIGH_LENGTH * s1 + dz2
        feet += (
            _HIP_LIST[leg][0] + x,
            _HIP_LIST[leg][1] + c0 * y - s0 * z,
            s0 * y + c0 * z,
        )
        jac += (
            0.0, z, dx2,
            -s0 * y - c0 * z, -s0 * dz1, -s0 * dz2,
            c0 * y - s0 * z, c0 * dz1, c0 * dz2,
        )  # fmt: skip
    return np.array(feet).reshape(4, 3), np.array(jac).reshape(4, 3, 3)


def forward_kinematics(q: np.ndarray) -> np.ndarray:
    """Foot positions (4, 3) in base_link for the 12 joint angles ``q``."""
    return leg_kinematics(q)[0]


def foot_jacobians(q: np.ndarray) -> np.ndarray:
    """Jacobians (4, 3, 3) of each foot position in base_link w.r.t. its leg's joints."""
    return leg_kinematics(q)[1]


def leg_inverse_kinematics(leg: int, foot: Sequence[float]) -> tuple[float, float, float]:
    """Joint angles (hip, thigh, calf) putting leg ``leg``'s foot at (x, y, z) in base_link.

    ``leg`` is 0..3 for FR, FL, RR, RL. The knee points backward; a target out of reach is
    pulled onto the reachable workspace and the angles are clipped to the joint limits.
    """
    hip = _HIP_LIST[leg]
    px = float(foot[0]) - hip[0]
    py = float(foot[1]) - hip[1]
    pz = float(foot[2])
    l1, l2 = THIGH_LENGTH, CALF_LENGTH
    # abduction: (py, pz) is (y, z) rotated by q0, z the sagittal-plane height (< 0)
    z = -math.sqrt(max(py * py + pz * pz - HIP_OFFSET * HIP_OFFSET, 1e-8))
    q0 = math.atan2(pz, py) - math.atan2(z, _SIDE_OFFSET_LIST[leg])
    q0 = (q0 + math.pi) % (2.0 * math.pi) - math.pi
    # sagittal two-link chain
    r = math.sqrt(max(px * px + z * z, 1e-12))
    if r > _MAX_REACH:
        px, z, r = px * _MAX_REACH / r, z * _MAX_REACH / r, _MAX_REACH
    cos_knee = (r * r - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
    q2 = -math.acos(min(1.0, max(-1.0, cos_knee)))
    q1 = math.atan2(-px, -z) - math.atan2(l2 * math.sin(q2), l1 + l2 * math.cos(q2))
    lo, hi = _LOWER_LIST, _UPPER_LIST
    return (
        min(hi[0], max(lo[0], q0)),
        min(hi[1], max(lo[1], q1)),
        min(hi[2], max(lo[2], q2)),
    )


def inverse_kinematics(feet: np.ndarray) -> np.ndarray:
    """Joint angles (12,) putting the feet (4, 3, base_link) where asked (all four legs)."""
    ps = np.asarray(feet, dtype=float).reshape(4, 3).tolist()
    out: list[float] = []
    for leg in range(4):
        out += leg_inverse_kinematics(leg, ps[leg])
    return np.array(out)


def gravity_torques(q: np.ndarray, gravity_body: Sequence[float]) -> np.ndarray:
    """Joint torques (12,) that hold the legs' own weight, as if the body were fixed.

    Uses the link masses and centres of mass of the URDF (hip link, thigh, calf + toe).
    Adding these to ``-J^T f`` makes the foot forces what the MPC asked for although the
    MPC's lumped body includes the legs.

    Args:
        q: the 12 joint angles (rad).
        gravity_body: gravity acceleration expressed in base_link (m/s^2), R^T (0, 0, -g).

    """
    qs = np.asarray(q, dtype=float).reshape(12).tolist()
    gx, gy, gz = (float(v) for v in gravity_body)
    l1 = THIGH_LENGTH
    ctx, ctz = THIGH_COM[0], THIGH_COM[2]
    ccx, ccz = CALF_COM[0], CALF_COM[2]
    out: list[float] = []
    for leg in range(4):
        q0, q1, q2 = qs[3 * leg : 3 * leg + 3]
        side = SIDE_SIGN_LIST[leg]
        s0, c0 = math.sin(q0), math.cos(q0)
        s1, c1 = math.sin(q1), math.cos(q1)
        s12, c12 = math.sin(q1 + q2), math.cos(q1 + q2)
        # gravity in the hip frame (rotated by the abduction angle)
        hy, hz = c0 * gy + s0 * gz, -s0 * gy + c0 * gz
        y_thigh = side * HIP_OFFSET
        # centres of mass relative to the hip joint, hip frame
        tx, ty, tz = ctx * c1 + ctz * s1, y_thigh - side * THIGH_COM[1], -ctx * s1 + ctz * c1
        kx, kz = -l1 * s1, -l1 * c1
        cdx, cdz = ccx * c12 + ccz * s12, -ccx * s12 + ccz * c12  # calf CoM from the knee
        cx, cz = kx + cdx, kz + cdz
        m_h, m_t, m_c = HIP_MASS, THIGH_MASS, CALF_MASS
        hcx, hcy, hcz = HIP_COM_LIST[leg]
        # motor torque = -(axis . sum r x m g) over the links beyond the joint
        tau_knee = -m_c * (cdz * gx - cdx * hz)
        tau_thigh = -(m_t * (tz * gx - tx * hz) + m_c * (cz * gx - cx * hz))
        tau_hip = -(
            m_h * (hcy * hz - hcz * hy) + m_t * (ty * hz - tz * hy) + m_c * (y_thigh * hz - cz * hy)
        )
        out += (tau_hip, tau_thigh, tau_knee)
    return np.array(out)


def jacobian_inverses(jac: np.ndarray, damping: float = 1e-4) -> np.ndarray:
    """Inverses (4, 3, 3) of the foot Jacobians, damped near singularities.

    Away from singularities (|det J| >= 1e-4 m^3; about 0.01 in the nominal stance) this is the
    exact inverse; otherwise J^T (J J^T + damping I)^-1, which keeps a stretched leg's joint
    velocities bounded (``damping`` in m^2).
    """
    js = np.asarray(jac, dtype=float).reshape(36).tolist()
    out: list[float] = []
    for leg in range(4):
        a, b, c, d, e, f, g, h, i = js[9 * leg : 9 * leg + 9]
        co0, co1, co2 = e * i - f * h, f * g - d * i, d * h - e * g
        det = a * co0 + b * co1 + c * co2
        if abs(det) < 1e-4:
            m = np.array(js[9 * leg : 9 * leg + 9]).reshape(3, 3)
            out += (m.T @ np.linalg.inv(m @ m.T + damping * _EYE3)).reshape(9).tolist()
            continue
        k = 1.0 / det
        out += (
            co0 * k, (c * h - b * i) * k, (b * f - c * e) * k,
            co1 * k, (a * i - c * g) * k, (c * d - a * f) * k,
            co2 * k, (b * g - a * h) * k, (a * e - b * d) * k,
        )  # fmt: skip
    return np.array(out).reshape(4, 3, 3)


def solve_leg_velocities(jac: np.ndarray, foot_velocities: np.ndarray) -> np.ndarray:
    """Joint velocities (12,) giving the feet velocities (4, 3) relative to base_link."""
    v = np.asarray(foot_velocities, dtype=float).reshape(4, 3, 1)
    return (jacobian_inverses(jac) @ v).reshape(12)
