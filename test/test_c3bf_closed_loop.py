"""Closed-loop simulations (no ROS, no PyBullet): the filter keeps the robot out of every
inflated circle, the unfiltered reference collides.

Euler integration with dt = 2 ms (4-5 ms for the multi-obstacle runs); the reference is a
saturated P tracker of a constant target velocity (and, for z, of the nominal height).
"""

import numpy as np
import pytest

from safe_legged_c3bf.c3bf import (
    FilterStatus,
    HolonomicHeightModel,
    Obstacles,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
)
from safe_legged_c3bf.c3bf.lie import PLANE_AXES


def wrap(a):
    return np.arctan2(np.sin(a), np.cos(a))


def simulate(model, flt, x0, obs, u_ref_fn, T, dt=0.002, yaw=None, u_min=None, u_max=None):
    """Return (trajectory, min over time of distance-to-centre minus TRUE radius, statuses)."""
    x = np.array(x0, dtype=float)
    traj, dmin, statuses = [x.copy()], np.inf, []
    for _ in range(int(round(T / dt))):
        u_ref = u_ref_fn(x)
        if flt is None:
            u = np.clip(u_ref, u_min, u_max)
        else:
            res = flt.filter(x, u_ref, obs, yaw=yaw)
            u = res.u_safe
            statuses.append(res.status)
            assert np.isfinite(u).all()
        x = x + dt * (model.f(x, yaw) + model.g(x, yaw) @ u)
        obs = obs.advanced(dt)
        P = model.point_kinematics(x, yaw).position[PLANE_AXES[obs.plane]]
        dmin = min(dmin, float(np.min(np.linalg.norm(obs.center - P, axis=1) - obs.radius)))
        traj.append(x.copy())
    return np.array(traj), dmin, statuses


UNI_MIN, UNI_MAX = np.array([-2.0, -4.0]), np.array([2.0, 4.0])


def unicycle_tracker(v_d=1.0, heading=0.0):
    def u_ref(x):
        a = 2.0 * (v_d - x[3])
        alpha = 4.0 * wrap(heading - x[2]) - 3.0 * x[4]
        return np.clip([a, alpha], UNI_MIN, UNI_MAX)

    return u_ref


UNICYCLE_CASES = {
    "static_offset": Obstacles.vertical([[5.0, 0.1]], [0.6]),
    "static_dead_ahead": Obstacles.vertical([[5.0, 0.0]], [0.6]),
    "head_on_moving": Obstacles.vertical([[8.0, 0.1]], [0.6], [[-1.0, 0.0]]),
    "crossing": Obstacles.vertical([[5.2, -5.0]], [0.6], [[0.0, 1.0]]),
}


@pytest.mark.parametrize("offset", [0.0, 0.2])
@pytest.mark.parametrize("case", list(UNICYCLE_CASES))
def test_unicycle_never_enters_obstacle_and_collides_without_filter(case, offset):
    model = UnicycleModel(offset=offset)
    obs = UNICYCLE_CASES[case]
    flt = SafetyFilter(model, u_min=UNI_MIN, u_max=UNI_MAX)
    x0 = [0.0, 0.0, 0.0, 1.0, 0.0]
    traj, dmin, statuses = simulate(model, flt, x0, obs, unicycle_tracker(), T=10.0)
    _, dmin_free, _ = simulate(model, None, x0, obs, unicycle_tracker(), T=10.0,
                               u_min=UNI_MIN, u_max=UNI_MAX)
    assert dmin_free < 0.0  # the reference alone collides
    assert dmin > 0.0  # the filtered robot never enters the inflated circle
    assert FilterStatus.EMERGENCY not in statuses
    if offset > 0 and case != "static_dead_ahead":
        # With a body-point offset the filter steers around and the robot carries on.
        assert traj[-1, 0] > 8.0 and abs(traj[-1, 3] - 1.0) < 0.05


def test_xz_robot_ducks_under_a_low_bar_and_regains_height():
    model = XZDoubleIntegratorModel()
    lo, hi = np.array([-2.0, -3.0]), np.array([2.0, 3.0])
    z0, bar_x = 0.30, 4.0
    # Bar: 5 cm radius cross-section at 0.45 m, robot body 0.3 m high -> r = 0.05 + 0.15.
    bar = Obstacles.horizontal([[bar_x, 0.45]], [0.05 + 0.30 / 2])

    def u_ref(x):  # keep 0.8 m/s forward and the nominal height
        return np.clip([2.0 * (0.8 - x[2]), 20.0 * (z0 - x[1]) - 8.0 * x[3]], lo, hi)

    flt = SafetyFilter(model, u_min=lo, u_max=hi)
    traj, dmin, _ = simulate(model, flt, [0.0, z0, 0.8, 0.0], bar, u_ref, T=12.0)
    _, dmin_free, _ = simulate(model, None, [0.0, z0, 0.8, 0.0], bar, u_ref, T=12.0,
                               u_min=lo, u_max=hi)
    assert dmin_free < 0.0 and dmin > 0.0
    under = np.argmin(np.abs(traj[:, 0] - bar_x))
    assert traj[under, 1] < 0.45 - 0.20  # ducked below the bar's inflated circle
    assert traj[:, 1].min() < z0 - 0.03
    assert traj[-1, 0] > bar_x + 3.0  # got past
    assert abs(traj[-1, 1] - z0) < 5e-3 and abs(traj[-1, 3]) < 1e-2  # height regained


def test_combined_model_ducks_and_swerves_in_one_qp():
    """Unicycle + vertical axis: a pillar and a bar handled together (stacked input)."""
    model = UnicycleHeightModel(offset=0.2)
    lo, hi = np.array([-2.0, -4.0, -3.0]), np.array([2.0, 4.0, 3.0])
    z0 = 0.3
    obs = Obstacles.concatenate(
        Obstacles.vertical([[3.0, 0.15]], [0.5]),
        Obstacles.horizontal([[7.0, 0.45]], [0.2]),
    )

    def u_ref(x):
        a = 2.0 * (1.0 - x[3])
        alpha = 4.0 * wrap(-x[2]) - 3.0 * x[4]
        a_z = 20.0 * (z0 - x[5]) - 8.0 * x[6]
        return np.clip([a, alpha, a_z], lo, hi)

    flt = SafetyFilter(model, u_min=lo, u_max=hi)
    x0 = [0.0, 0.0, 0.0, 1.0, 0.0, z0, 0.0]
    traj, dmin, statuses = simulate(model, flt, x0, obs, u_ref, T=14.0, dt=0.004)
    _, dmin_free, _ = simulate(model, None, x0, obs, u_ref, T=14.0, dt=0.004, u_min=lo, u_max=hi)
    assert dmin_free < 0.0 and dmin > 0.0
    assert np.abs(traj[:, 1]).max() > 0.1  # swerved around the pillar
    assert traj[:, 5].min() < 0.45 - 0.2  # ducked under the bar
    assert traj[-1, 0] > 10.0 and abs(traj[-1, 5] - z0) < 5e-3
    assert FilterStatus.EMERGENCY not in statuses


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ten_random_obstacles_never_entered(seed):
    rng = np.random.default_rng(seed)
    model = HolonomicHeightModel() if seed == 2 else UnicycleHeightModel(offset=0.2)
    n = 10
    centers = np.c_[rng.uniform(2.0, 14.0, n), rng.uniform(-3.0, 3.0, n)]
    obs = Obstacles.vertical(centers, rng.uniform(0.3, 0.7, n), rng.uniform(-0.5, 0.5, (n, 2)))
    lo, hi = np.array([-2.0, -4.0, -3.0]), np.array([2.0, 4.0, 3.0])
    z0 = 0.3
    if model.needs_yaw:
        lo, hi = np.array([-2.0, -2.0, -3.0]), np.array([2.0, 2.0, 3.0])
        x0 = [0.0, 0.0, 1.0, 0.0, z0, 0.0]

        def u_ref(x):  # body frame == odom at yaw 0
            return np.clip([2.0 * (1.0 - x[2]), -2.0 * x[3], 20 * (z0 - x[4]) - 8 * x[5]],
                           lo, hi)
    else:
        x0 = [0.0, 0.0, 0.0, 1.0, 0.0, z0, 0.0]

        def u_ref(x):
            return np.clip([2.0 * (1.0 - x[3]), 4.0 * wrap(-x[2]) - 3.0 * x[4],
                            20 * (z0 - x[5]) - 8 * x[6]], lo, hi)

    yaw = 0.0 if model.needs_yaw else None
    flt = SafetyFilter(model, u_min=lo, u_max=hi)
    traj, dmin, statuses = simulate(model, flt, x0, obs, u_ref, T=14.0, dt=0.005, yaw=yaw)
    _, dmin_free, _ = simulate(model, None, x0, obs, u_ref, T=14.0, dt=0.005, yaw=yaw,
                               u_min=lo, u_max=hi)
    assert dmin_free < 0.0
    assert dmin > 0.0
    assert FilterStatus.EMERGENCY not in statuses
    assert traj[-1, 0] > 5.0  # made progress into the field (not frozen at the start)
