"""The anti-windup's measured velocity averaged over a window (``safety/moving_mean.py``).

A walking robot's measured velocity swings within every step; against the raw measurement the
anti-windup holds a command back in one direction or the other for much of the gait. Averaged
over the gait cycle, it holds back only a command that really leads the robot.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_safety_cycle_boundaries import PERIOD, T0, base

from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.moving_mean import MovingMean
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle


def test_the_mean_covers_the_window_and_restarts_when_time_goes_back():
    mean = MovingMean(0.5)
    for k in range(10):
        out = mean.add(0.1 * k, np.array([float(k)]))
    assert out[0] == pytest.approx(np.mean([4, 5, 6, 7, 8, 9]))  # t in [0.4, 0.9]
    assert mean.add(0.2, np.array([3.0]))[0] == 3.0  # back in time: only the new sample
    assert np.isnan(mean.add(0.3, np.array([math.nan]))).all()  # returned, not added
    assert mean.add(0.3, np.array([5.0]))[0] == pytest.approx(4.0)


def test_window_zero_is_the_latest_sample():
    mean = MovingMean(0.0)
    mean.add(0.0, np.array([1.0, 2.0]))
    assert mean.add(0.02, np.array([3.0, -1.0])).tolist() == [3.0, -1.0]
    with pytest.raises(ValueError):
        MovingMean(-0.1)


def _side_step_with_sway(window: float, phase: float, set_later: bool = False) -> list[float]:
    """Side-step commands while the measured vy follows the command plus a 1 Hz, 0.3 m/s sway.

    The biped's side-step limits, band and gait cycle (config/robots/biped.yaml); the sway
    starts at ``phase`` [rad]. ``set_later``: the window is set by ``set_params`` after the
    cycle was built with none (a parameter changed at run time).
    """
    params = FilterParams(model="unicycle_lateral", max_lateral_speed=0.08, windup_band=0.10,
                          windup_window=window)
    cycle = SafetyFilterCycle(params.updated(windup_window=0.0) if set_later else params)
    if set_later:
        cycle.set_params(params)
    ref, vy, out = VelocityCommand(0.0, -0.08), 0.0, []
    for k in range(100):
        t = T0 + k * PERIOD
        sway = 0.3 * math.sin(2.0 * math.pi * (t - T0) + phase) if k else 0.0  # from rest
        cmd = cycle.step(t, ref, t, base(t, VelocityCommand(0.0, vy + sway)), [], t).command
        vy += min(PERIOD / 0.5, 1.0) * (cmd.vy - vy)  # the walk follows with a 0.5 s lag
        out.append(cmd.vy)
    return out


def test_averaged_over_the_gait_cycle_a_side_step_is_held_less_by_the_sway():
    """Time for the command to reach 0.06 of a 0.08 m/s side-step, over 8 phases of the sway.

    The average lags the robot, so it may hold a command a little longer at one phase; over
    the gait it holds it much less (1.20 s raw against 0.93 s averaged, measured).
    """
    def reach(commands: list[float]) -> float:
        return PERIOD * next((k for k, v in enumerate(commands) if v <= -0.06), len(commands))

    phases = np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)
    raw = np.mean([reach(_side_step_with_sway(0.0, ph)) for ph in phases])
    averaged = np.mean([reach(_side_step_with_sway(1.0, ph)) for ph in phases])
    assert averaged < 0.85 * raw, (raw, averaged)


def test_a_window_set_at_run_time_applies():
    assert _side_step_with_sway(1.0, 2.0, set_later=True) == _side_step_with_sway(1.0, 2.0)
    assert _side_step_with_sway(1.0, 2.0) != _side_step_with_sway(0.0, 2.0)
