"""The filter cycle under untrusted inputs: stamps from the future, obstacles that vanish."""

from __future__ import annotations

import numpy as np
import pytest
from filter_harness import ScriptedObstacle, SimpleRobot

from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import CycleStatus, SafetyFilterCycle

DT = 1.0 / FilterParams().rate
# Its inflated circle (0.25 + 0.41 + 0.05 + 0.03 m) ends ~0.1 m ahead of the body point.
AHEAD = ScriptedObstacle("walker", np.array([1.0, 0.0, 0.5]))
REF = VelocityCommand(0.5, 0.0, 0.0, 0.0)


def cruise(cycle, robot, obstacles, t0=0.0, steps=50):
    """Drive the cycle and robot for ``steps`` cycles; return the last output and time."""
    out, t = None, t0
    for k in range(steps):
        t = t0 + k * DT
        out = cycle.step(t, REF, t, robot.base_state(t), [o.at(t) for o in obstacles], t)
        robot.step(out.command, DT)
    return out, t


@pytest.mark.parametrize("which", ["odom", "obstacles", "reference"])
def test_a_stamp_from_the_future_is_never_fresh(which):
    params = FilterParams()
    cycle = SafetyFilterCycle(params)
    robot = SimpleRobot(vx=0.5)
    cruise(cycle, robot, [], steps=20)
    t = 1.0
    ahead = params.max_future_stamp + 1e-3
    stamps = {"odom": t, "obstacles": t, "reference": t, which: t + ahead}
    base = robot.base_state(stamps["odom"])
    out = cycle.step(t, REF, stamps["reference"], base, [], stamps["obstacles"])
    if which == "reference":
        assert out.reference_stale and out.reference.vx == 0.0
    else:
        assert out.status is CycleStatus.STALE_INPUT
        assert out.command.vx < 0.5  # braking
    # Within the tolerance (clock jitter between processes) it is fresh.
    within = params.max_future_stamp - 1e-3
    stamps[which] = t + DT + within
    base = robot.base_state(stamps["odom"])
    out = SafetyFilterCycle(params).step(
        t + DT, REF, stamps["reference"], base, [], stamps["obstacles"]
    )
    assert out.status is not CycleStatus.STALE_INPUT and not out.reference_stale


def test_an_obstacle_that_vanishes_inside_the_stopping_distance_brakes_to_a_stop():
    params = FilterParams()
    cycle = SafetyFilterCycle(params)
    robot = SimpleRobot(vx=0.5)
    out, t = cruise(cycle, robot, [AHEAD], steps=2)
    speeds = []
    for k in range(1, 80):  # the walker is gone from the list (a drop-out, a lost track)
        t += DT
        out = cycle.step(t, REF, t, robot.base_state(t), [], t)
        robot.step(out.command, DT)
        speeds.append(out.command.vx)
        if k == 1:
            assert out.status is CycleStatus.EMERGENCY_BRAKE
            assert "'walker' vanished" in out.text
    stop = next(k for k, v in enumerate(speeds) if v == 0.0)
    # brake_decel per cycle, from the speed it had: exactly the braking profile
    v0 = speeds[0] + params.brake_decel * DT
    assert stop == pytest.approx(v0 / (params.brake_decel * DT), abs=1.0)
    assert speeds[stop + 1] > 0.0  # stopped once: the reference may move it again
    assert out.status is not CycleStatus.EMERGENCY_BRAKE


def test_an_obstacle_that_vanishes_far_away_does_not_brake():
    params = FilterParams()
    cycle = SafetyFilterCycle(params)
    robot = SimpleRobot(vx=0.5)
    far = ScriptedObstacle("far", np.array([6.0, 3.0, 0.5]))
    out, t = cruise(cycle, robot, [far], steps=5)
    t += DT
    out = cycle.step(t, REF, t, robot.base_state(t), [], t)
    assert out.status is not CycleStatus.EMERGENCY_BRAKE


def test_a_vanished_obstacle_is_remembered_only_vanished_memory_seconds():
    params = FilterParams(vanished_memory=0.2)
    cycle = SafetyFilterCycle(params)
    robot = SimpleRobot(vx=0.5)
    out, t = cruise(cycle, robot, [AHEAD], steps=3)
    t += params.vanished_memory + 0.05  # the next list comes after the memory ran out
    out = cycle.step(t, REF, t, robot.base_state(t), [], t)
    assert out.status is not CycleStatus.EMERGENCY_BRAKE
