"""Gait schedule, sides and command filter of the biped controller, without simulation."""

import numpy as np
import pytest

from safe_legged_c3bf.gait.biped.command_filter import CommandFilter
from safe_legged_c3bf.gait.biped.footstep_planner import Footstep, FootstepPlanner
from safe_legged_c3bf.gait.biped.gait_schedule import GaitMode, GaitSchedule, LegPhase
from safe_legged_c3bf.gait.biped.params import BipedParams
from safe_legged_c3bf.gait.biped.side import SIDES, Side
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand


def standing_feet():
    half = 0.5 * BipedParams().gait.step_width
    return {side: np.array([0.0, side.sign * half, 0.0, 0.0]) for side in SIDES}


def make_schedule():
    params = BipedParams()
    schedule = GaitSchedule(params.gait, FootstepPlanner(params.gait, params.steps))
    schedule.initialize(0.0, standing_feet())
    return schedule, CommandFilter(params.command)


def test_sides_are_typed_and_compare_to_their_letters():
    assert Side.LEFT == "l" and Side.RIGHT.other is Side.LEFT
    assert Side.LEFT.sign == 1.0 and Side.RIGHT.sign == -1.0
    assert Side.RIGHT.joints == slice(6, 12)
    assert Footstep("r", 0.0, 0.0, 0.0).side is Side.RIGHT
    with pytest.raises(ValueError):
        Footstep("x", 0.0, 0.0, 0.0)


def test_stands_until_asked_to_move():
    schedule, command = make_schedule()
    for k in range(10):
        assert not schedule.advance(0.005 * k, standing_feet(), command)
    assert schedule.mode is GaitMode.STAND and schedule.step is None
    assert all(p is LegPhase.STANCE for p in schedule.phases(0.05).values())
    assert schedule.stance_weight(0.05, Side.LEFT) == 1.0
    np.testing.assert_allclose(schedule.stand_zmp_at(np.array([0.0, 5.0])), 0.0, atol=0.03)


def test_walk_starts_with_the_foot_on_the_side_of_the_motion_and_alternates():
    schedule, command = make_schedule()
    command.update(VelocityCommand(vy=0.05), 0.5)
    schedule.advance(0.0, standing_feet(), command)
    step = schedule.step
    assert schedule.mode is GaitMode.WALK and step.swing is Side.LEFT
    assert step.hold == pytest.approx(schedule.gait.start_delay)
    assert schedule.phases(step.t_lift - 1e-3)[Side.LEFT] is LegPhase.STANCE
    phases = schedule.phases(step.t_lift + 1e-3)
    assert phases[Side.LEFT] is LegPhase.SWING and phases[Side.RIGHT] is LegPhase.STANCE
    assert schedule.stance_weight(step.t_lift + 1e-3, Side.LEFT) == 0.0
    assert schedule.stance_weight(step.t_lift + 1e-3, Side.RIGHT) == 1.0
    # touchdown where the foot is measured: it becomes the support of the next step
    landed = {
        Side.LEFT: np.array([0.02, 0.13, 0.004, 0.01]),
        Side.RIGHT: standing_feet()[Side.RIGHT],
    }
    assert schedule.advance(step.t_end, landed, command)
    assert schedule.steps_taken == 1 and schedule.step.swing is Side.RIGHT
    support = schedule.step.support
    assert (support.side, support.x, support.y, support.yaw) == (Side.LEFT, 0.02, 0.13, 0.01)
    assert schedule.feet[Side.LEFT][2] == schedule.ground_z


def test_stops_after_a_step_that_aligns_the_feet():
    schedule, command = make_schedule()
    command.update(VelocityCommand(yaw_rate=0.01), 0.005)
    schedule.advance(0.0, standing_feet(), command)
    command.update(VelocityCommand(), 1.0)
    assert not command.moving
    feet = standing_feet()
    t = 0.0
    for _ in range(4):  # the first step aligns the feet again: stand at its touchdown
        if schedule.step is None:
            break
        t = schedule.step.t_end
        target = schedule.step.target
        feet[target.side] = np.array([target.x, target.y, 0.0, target.yaw])
        schedule.advance(t, feet, command)
    assert schedule.mode is GaitMode.STAND and schedule.steps_taken == 1
    assert schedule.stand_zmp.t0 == pytest.approx(t)


def test_the_walk_starts_above_a_threshold_and_a_stop_is_finished_before_a_restart():
    limits = BipedParams().command
    command = CommandFilter(limits)
    command.update(VelocityCommand(vx=0.5 * limits.start_threshold), 0.01)
    assert not command.moving  # solver noise does not start a walk
    command.update(VelocityCommand(vx=0.05), 0.01)
    assert command.moving
    command.update(VelocityCommand(vx=0.5 * (limits.start_threshold + limits.stop_threshold)), 1.0)
    assert command.moving  # between the thresholds a walk goes on
    command.update(VelocityCommand(), 1.0, standing=False)
    assert not command.moving  # a stop is obeyed at once
    command.update(VelocityCommand(vx=0.1), 0.01, standing=False)
    assert not command.moving  # ... and finished: no restart before the robot stands
    command.update(VelocityCommand(vx=0.1), 0.01, standing=True)
    assert command.moving


def test_a_stand_is_settled_once_the_zmp_is_back_between_the_feet():
    schedule, command = make_schedule()
    assert schedule.settled(0.0)  # standing from the start: nothing to wait for
    command.update(VelocityCommand(yaw_rate=0.01), 0.005)
    schedule.advance(0.0, standing_feet(), command)
    assert not schedule.settled(0.0)  # walking
    command.update(VelocityCommand(), 1.0, standing=False)
    feet = standing_feet()
    while schedule.step is not None:
        t = schedule.step.t_end
        target = schedule.step.target
        feet[target.side] = np.array([target.x, target.y, 0.0, target.yaw])
        schedule.advance(t, feet, command)
    stop = schedule.gait.stop_double_support
    assert not schedule.settled(t + 0.5 * stop)
    assert schedule.settled(t + stop)


def test_stop_thresholds_are_validated():
    with pytest.raises(ValueError, match="stop_threshold"):
        BipedParams.from_dict({"command": {"stop_threshold": 0.01, "start_threshold": 0.005}})
    with pytest.raises(ValueError, match="stop_threshold"):
        BipedParams.from_dict({"command": {"stop_threshold": 0.0}})
