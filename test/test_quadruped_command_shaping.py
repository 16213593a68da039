"""Command filter and integral action of the quadruped controller (command_shaping)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from safe_legged_c3bf.gait.quadruped.command_shaping import CommandFilter, IntegralAction
from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams
from safe_legged_c3bf.gait.quadruped.state_estimate import BodyEstimate
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand


def body(vx: float = 0.0, vy: float = 0.0, wz: float = 0.0) -> BodyEstimate:
    """Level body at the origin moving at (vx, vy) with yaw rate wz (odom axes)."""
    zero = np.zeros(3)
    return BodyEstimate(zero, np.eye(3), zero, np.array([vx, vy, 0.0]), np.array([0, 0, wz]),
                        zero, zero)  # fmt: skip


def test_command_filter_clips_rate_limits_and_settles():
    f = CommandFilter([1.0, 0.5, 1.5], [2.0, 2.0, 4.0])
    assert f.update(VelocityCommand(vx=3.0, vy=-1.0, yaw_rate=math.nan), 0.1) == pytest.approx(
        (0.2, -0.2, 0.0)
    )
    assert f.motion_requested and not f.settled
    for _ in range(10):
        out = f.update(VelocityCommand(vx=3.0, vy=-1.0), 0.1)
    assert out == pytest.approx((1.0, -0.5, 0.0))
    assert f.settled
    np.testing.assert_allclose(f.value, [1.0, -0.5, 0.0])
    for _ in range(10):
        f.update(VelocityCommand(), 0.1)
    assert not f.motion_requested and f.settled
    f.update(VelocityCommand(vx=0.5), 0.1)
    f.reset()
    assert not f.motion_requested and f.settled and not f.value.any()


def test_integral_action_bounds_and_clears():
    p = QuadrupedParams()
    ia = IntegralAction(p)
    # body slower than commanded while trotting with a settled command: the correction grows
    for _ in range(1000):
        out = ia.update(0.05, body(vx=0.3), 0.01, True, True, 1.0, 0.0, 0.5, 0.0, 0.0)
    assert ia.height_correction == pytest.approx(p.max_height_correction)
    assert out[0] == pytest.approx(0.5 + p.max_velocity_correction)
    # unsettled command: held
    assert ia.update(0.0, body(), 0.01, True, False, 1.0, 0.0, 0.5, 0.0, 0.0)[0] == out[0]
    # standing: the velocity corrections are cleared, the height correction is kept
    assert ia.update(0.0, body(), 0.01, False, True, 1.0, 0.0, 0.5, 0.1, 0.2) == (0.5, 0.1, 0.2)
    assert not ia.velocity_correction.any()
    assert ia.height_correction == pytest.approx(p.max_height_correction)
    ia.reset()
    assert ia.height_correction == 0.0
