"""Closed-loop PyBullet runs of the quadruped controller (slow).

The 'done when' numbers of the quadruped controller issue: velocity tracking, body height
following a drop and return while walking, stopping and standing on a zero command, and
random piecewise-constant commands without falling. The random runs here are 5 seeds x 30 s
of sim time to keep the slow tests within their time budget; the benchmark
(``benchmarks/quadruped_tracking.py``) runs the full 5 seeds x 60 s.
"""

from __future__ import annotations

import numpy as np
import pytest
from quadruped_harness import (
    QuadrupedSim,
    RunLog,
    run_height,
    run_random,
    run_tracking,
)

from safe_legged_c3bf.gait.quadruped.controller import QuadrupedMpcController
from safe_legged_c3bf.gait.quadruped.gait_schedule import GaitMode
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand

pytestmark = pytest.mark.slow

TOLERANCE = {"vx": 0.10, "vy": 0.15, "yaw_rate": 0.15}


@pytest.mark.parametrize("kind", ["vx", "vy", "yaw_rate"])
def test_velocity_tracking(kind):
    result = run_tracking(kind, QuadrupedMpcController())
    assert result.ok, "the robot fell"
    assert result.values["relative_error"] <= TOLERANCE[kind], result.values
    assert result.values["cross_axis_max"] < 0.05, result.values
    assert result.mpc_failures == 0


def test_body_height_follows_drop_and_return_while_walking():
    result = run_height(QuadrupedMpcController())
    assert result.ok, "the robot fell"
    assert result.values["max_abs_error"] <= 0.015, result.values
    assert result.values["lowest_mean"] == pytest.approx(0.20, abs=0.01)
    assert result.values["forward_speed"] == pytest.approx(0.3, rel=0.1)


def test_zero_command_stops_and_stands():
    controller = QuadrupedMpcController()
    log = RunLog()

    def command(t: float) -> VelocityCommand:
        return VelocityCommand(0.5, 0.1, 0.0, 0.3) if 0.5 <= t < 3.0 else VelocityCommand()

    with QuadrupedSim() as sim:
        assert sim.run(controller, command, 4.0, log)
        assert controller.mode is GaitMode.STAND
        start = sim.base_state()
        assert sim.run(controller, command, 2.0, log)
        end = sim.base_state()
    d = log.arrays()
    moved = (d["t"] > 1.0) & (d["t"] < 3.0)
    assert np.linalg.norm(d["position"][moved][-1, :2] - d["position"][moved][0, :2]) > 0.5
    # standing still: no drift, level, at the target height
    assert np.linalg.norm(end.position[:2] - start.position[:2]) < 0.01
    assert abs(end.yaw - start.yaw) < 0.01
    assert np.linalg.norm(end.linear_velocity) < 0.02
    assert np.abs(end.rpy[:2]).max() < 0.03
    assert end.position[2] == pytest.approx(controller.height_target, abs=0.01)


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_random_commands_do_not_make_it_fall(seed):
    result = run_random(seed, 30.0, QuadrupedMpcController())
    assert result.ok, f"fell after {result.sim_time:.2f} s"
    assert result.sim_time == pytest.approx(30.0)
    assert result.values["max_abs_roll"] < 0.3, result.values
    assert result.values["max_abs_pitch"] < 0.3, result.values
    assert result.values["min_height"] > 0.14, result.values
    assert result.mpc_failures == 0
