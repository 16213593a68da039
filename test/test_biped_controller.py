"""BipedZmpController: interface, safety behaviour and short standing simulations."""

import numpy as np
import pytest
from biped_harness import BipedSim, constant

from safe_legged_c3bf.gait.biped.controller import BipedZmpController
from safe_legged_c3bf.gait.biped.params import BipedParams
from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import GaitController, VelocityCommand
from safe_legged_c3bf.interfaces.joint_command import JointCommand
from safe_legged_c3bf.sim.robots import robot_spec


def standing_inputs():
    spec = robot_spec("biped")
    ctrl = BipedZmpController()
    q = np.array([spec.standing_pose[n] for n in ctrl.joint_names])
    base = BaseState(position=[0.0, 0.0, spec.spawn_height - 0.005])
    return ctrl, base, q


def test_implements_the_gait_controller_interface():
    ctrl = BipedZmpController()
    for name in ("joint_names", "control_period", "update"):
        assert hasattr(ctrl, name) and hasattr(GaitController, "update")
    spec = robot_spec("biped")
    assert set(ctrl.joint_names) == set(spec.standing_pose)
    assert ctrl.control_period == pytest.approx(BipedParams().gait.control_period)


def test_update_returns_a_valid_command():
    ctrl, base, q = standing_inputs()
    cmd = ctrl.update(0.0, base, q, np.zeros(12), VelocityCommand())
    assert isinstance(cmd, JointCommand)
    assert cmd.names == ctrl.joint_names
    assert cmd.is_finite() and np.all(cmd.kp >= 0) and np.all(cmd.kd >= 0)
    # standing still: targets stay near the spawn posture (the CoM settles 5 mm lower)
    np.testing.assert_allclose(cmd.q, q, atol=0.05)
    assert ctrl.mode == "stand"


def test_invalid_measurements_give_a_safe_hold_command():
    ctrl, base, q = standing_inputs()
    first = ctrl.update(0.0, base, q, np.zeros(12), VelocityCommand())
    bad = BaseState(position=[np.nan, 0.0, 0.8])
    cmd = ctrl.update(0.005, bad, q, np.zeros(12), VelocityCommand())
    assert cmd.is_finite()
    np.testing.assert_allclose(cmd.q, first.q - 0.5 * ctrl.control_period * first.dq)


def test_commands_are_clipped_and_rate_limited():
    ctrl, base, q = standing_inputs()
    lim = ctrl.params.command
    ctrl.update(0.0, base, q, np.zeros(12), VelocityCommand(vx=5.0, vy=-5.0, yaw_rate=9.0))
    np.testing.assert_allclose(ctrl.command.target, [lim.vx_max, -lim.vy_max, lim.yaw_rate_max])
    assert abs(ctrl.command.velocity[0]) <= lim.accel_x * ctrl.control_period + 1e-12
    assert ctrl.mode == "walk"


def test_stands_still_in_simulation():
    sim = BipedSim()
    try:
        ctrl = BipedZmpController()
        log = sim.run(ctrl, 3.0, constant())
    finally:
        sim.close()
    d = log.arrays()
    assert not log.fell
    assert ctrl.mode == "stand" and ctrl.status.steps_taken == 0
    late = d["t"] > 1.0
    assert np.ptp(d["position"][late][:, 0]) < 0.005
    assert np.ptp(d["position"][late][:, 1]) < 0.005
    assert np.abs(d["rpy"][late][:, :2]).max() < 0.02
