"""The filter's side-step model (``model: unicycle_lateral``) in closed loop (no ROS).

A legged robot can leave a collision cone sideways as well as by braking and turning; the
unicycle model (the paper's) cannot say so. These cases compare both on the same robot.
"""

from __future__ import annotations

import numpy as np
import pytest
from filter_harness import ScriptedObstacle, SimpleRobot
from test_safety_cycle import min_gap, run

from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import CycleStatus, SafetyFilterCycle

HEAD_ON = ScriptedObstacle("head_on", np.array([6.0, 0.0, 0.5]), np.array([-0.4, 0.0, 0.0]))


def _lateral(**kw) -> FilterParams:
    return FilterParams(model="unicycle_lateral", **kw)


@pytest.mark.parametrize("body_model", ["body", "point"])
def test_a_head_on_walker_is_passed_by_stepping_aside(body_model):
    """The walker comes straight at the robot faster than it can back away: it steps aside."""
    robot = SimpleRobot(holonomic=True)
    cycle = SafetyFilterCycle(_lateral(body_model=body_model))
    log = run(cycle, robot, [HEAD_ON], VelocityCommand(0.5, 0.0, 0.0, 0.0), 16.0)
    statuses = {out.status for _, out, *_ in log}
    assert CycleStatus.EMERGENCY_BRAKE not in statuses
    assert min_gap(log) > 0.0, "the protected shape touched the walker"
    assert max(abs(out.command.vy) for _, out, *_ in log) > 0.05  # it did side-step
    assert robot.x > 4.0, "it went on towards its goal after the walker passed"


def test_no_side_step_without_a_reason():
    """On a free path the command has no lateral speed: the reference's is 0."""
    robot = SimpleRobot(holonomic=True)
    log = run(SafetyFilterCycle(_lateral()), robot, [], VelocityCommand(0.5, 0.0, 0.0, 0.2), 5.0)
    assert max(abs(out.command.vy) for _, out, *_ in log) < 1e-9
    assert abs(robot.y - SimpleRobot().y) < 2.0  # it drove its arc


@pytest.mark.parametrize("limit", [0.05, 0.2])
def test_the_side_step_stays_within_max_lateral_speed(limit):
    robot = SimpleRobot(holonomic=True)
    cycle = SafetyFilterCycle(_lateral(body_model="body", max_lateral_speed=limit))
    log = run(cycle, robot, [HEAD_ON], VelocityCommand(0.5, 0.0, 0.0, 0.0), 10.0)
    assert max(abs(out.command.vy) for _, out, *_ in log) <= limit + 1e-12


def test_the_unicycle_model_never_side_steps():
    robot = SimpleRobot(holonomic=True)
    cycle = SafetyFilterCycle(FilterParams(body_model="body"))
    log = run(cycle, robot, [HEAD_ON], VelocityCommand(0.5, 0.3, 0.0, 0.0), 10.0)
    assert max(abs(out.command.vy) for _, out, *_ in log) == 0.0


def test_the_lateral_weight_is_the_qp_weight_of_the_fourth_input():
    cycle = SafetyFilterCycle(_lateral(weights=(1.0, 0.2, 0.5), lateral_weight=0.25))
    assert cycle.filter.model.input_names == ("a", "alpha", "a_z", "a_l")
    np.testing.assert_allclose(np.diag(cycle.filter.weights), [1.0, 0.2, 0.5, 0.25])
