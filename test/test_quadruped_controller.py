"""QuadrupedMpcController: protocol, command handling and a short standing simulation."""

from __future__ import annotations

import numpy as np
import pytest
from biped_harness import stop_and_go
from quadruped_harness import QuadrupedSim, RunLog, constant, fallen

from safe_legged_c3bf.gait.factory import make_gait_controller
from safe_legged_c3bf.gait.quadruped import a1_kinematics as kin
from safe_legged_c3bf.gait.quadruped.controller import QuadrupedMpcController
from safe_legged_c3bf.gait.quadruped.gait_schedule import GaitMode
from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams
from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import GaitController, VelocityCommand

HEIGHT = 0.28


def standing_state(t: float = 0.0) -> tuple[BaseState, np.ndarray, np.ndarray]:
    """Level body at the nominal height with the feet on the ground under the hips."""
    q = kin.inverse_kinematics(kin.nominal_foot_positions(HEIGHT))
    return BaseState(position=[0.0, 0.0, HEIGHT], stamp=t), q, np.zeros(12)


def tick(controller, t, command, state=None):
    base, q, dq = state or standing_state(t)
    return controller.update(t, base, q, dq, command)


def test_implements_the_gait_controller_protocol():
    controller: GaitController = QuadrupedMpcController()
    assert controller.joint_names == kin.JOINT_NAMES
    assert 0.001 <= controller.control_period <= 0.005
    cmd = tick(controller, 0.0, VelocityCommand())
    assert cmd.names == kin.JOINT_NAMES
    assert cmd.is_finite()
    assert np.all(cmd.kp >= 0) and np.all(cmd.kd >= 0)
    # standing: all legs push down; the MPC carries the weight through -J^T f
    forces = controller.last_solution.forces
    assert forces[:, 2].sum() == pytest.approx(QuadrupedParams().mass * 9.81, rel=0.05)
    assert np.all(np.abs(cmd.tau) <= np.tile([20.0, 55.0, 55.0], 4))


def test_registry_and_config_file_build_the_controller():
    controller = make_gait_controller("quadruped")
    assert isinstance(controller, QuadrupedMpcController)
    assert controller.params == QuadrupedParams()


def test_zero_command_keeps_standing():
    controller = QuadrupedMpcController()
    for i in range(200):
        cmd = tick(controller, i * 0.002, VelocityCommand())
    assert controller.mode is GaitMode.STAND
    assert cmd.is_finite()
    np.testing.assert_allclose(controller.filtered_command, 0.0)


def test_motion_command_starts_trotting_smoothly():
    controller = QuadrupedMpcController()
    p = controller.params
    tick(controller, 0.0, VelocityCommand())
    tick(controller, 0.002, VelocityCommand(vx=5.0, vy=-5.0, yaw_rate=9.0))
    assert controller.mode is GaitMode.TROT
    # rate-limited: one tick of acceleration only
    np.testing.assert_allclose(
        controller.filtered_command,
        [p.max_linear_acceleration * 0.002, -p.max_linear_acceleration * 0.002,
         p.max_yaw_acceleration * 0.002],
    )  # fmt: skip
    for i in range(2, 2000):
        tick(controller, i * 0.002, VelocityCommand(vx=5.0, vy=-5.0, yaw_rate=9.0))
    # clipped to the limits
    np.testing.assert_allclose(
        controller.filtered_command, [p.max_forward_speed, -p.max_lateral_speed, p.max_yaw_rate]
    )


def test_vertical_speed_integrates_into_a_clamped_height_target():
    controller = QuadrupedMpcController()
    p = controller.params
    tick(controller, 0.0, VelocityCommand())
    assert controller.height_target == pytest.approx(HEIGHT)
    t = 0.0
    for _ in range(100):  # 0.2 s at -0.1 m/s
        t += 0.002
        tick(controller, t, VelocityCommand(vz=-0.1))
    assert controller.height_target == pytest.approx(HEIGHT - 0.02, abs=1e-9)
    for _ in range(1000):
        t += 0.002
        tick(controller, t, VelocityCommand(vz=-1.0))  # clipped to max_vertical_speed
    assert controller.height_target == pytest.approx(p.min_body_height)
    for _ in range(1000):
        t += 0.002
        tick(controller, t, VelocityCommand(vz=0.2))
    assert controller.height_target == pytest.approx(p.max_body_height)
    # vz alone does not make the robot trot
    assert controller.mode is GaitMode.STAND


def test_non_finite_inputs_give_a_damping_command():
    controller = QuadrupedMpcController()
    base, q, dq = standing_state()
    base.linear_velocity[0] = np.nan
    cmd = controller.update(0.0, base, q, dq, VelocityCommand(vx=0.5))
    assert cmd.is_finite()
    np.testing.assert_allclose(cmd.kp, 0.0)
    np.testing.assert_allclose(cmd.tau, 0.0)
    assert np.all(cmd.kd > 0)
    base, q, dq = standing_state()
    q[4] = np.inf
    cmd = controller.update(0.0, base, q, dq, VelocityCommand())
    assert cmd.is_finite()
    # a non-finite command is treated as zero
    cmd = tick(controller, 0.0, VelocityCommand(vx=np.nan, vz=np.inf))
    assert cmd.is_finite() and controller.mode is GaitMode.STAND


def test_time_going_backwards_resets():
    controller = QuadrupedMpcController()
    for i in range(100):
        tick(controller, 1.0 + i * 0.002, VelocityCommand(vx=0.5))
    assert controller.mode is GaitMode.TROT
    tick(controller, 0.0, VelocityCommand())
    assert controller.mode is GaitMode.STAND
    np.testing.assert_allclose(controller.filtered_command, 0.0)


def test_stands_in_simulation():
    controller = QuadrupedMpcController()
    log = RunLog()
    with QuadrupedSim() as sim:
        assert sim.run(controller, constant(), 1.5, log)
        base = sim.base_state()
    assert not fallen(base)
    assert controller.mode is GaitMode.STAND
    assert base.position[2] == pytest.approx(controller.height_target, abs=0.015)
    assert np.abs(base.rpy[:2]).max() < 0.03
    assert np.linalg.norm(base.linear_velocity) < 0.05
    assert controller.mpc_failures == 0


@pytest.mark.slow
@pytest.mark.parametrize(
    "command",
    [{"vx": 0.1}, {"vy": 0.08}, {"yaw_rate": 0.3}, {"vx": 3e-4}],
    ids=["forward", "sideways", "turning", "solver_noise"],
)
def test_stop_and_go_commands_do_not_topple_it(command):
    # A safety filter that holds and releases the robot every 0.9 s (the biped fell on this
    # until its stop was latched; the trot's command shaping has no latch and needs none:
    # 0 falls in benchmarks/stop_and_go.py --robot a1).
    with QuadrupedSim() as sim:
        assert sim.run(QuadrupedMpcController(), stop_and_go(0.9, 0.3, start=1.0, **command), 9.0)
        base = sim.base_state()
    assert np.abs(base.rpy[:2]).max() < 0.2
