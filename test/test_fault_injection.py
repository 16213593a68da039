"""Fault injection end to end: the default scenario, multi-process, one fault per run.

Each case states its expected behaviour (``faults.Fault.expect``) and checks it from ground
truth: no collision; ``continue``: the goal is reached; ``stop``: the robot stands;
``end``: the run ends naming the node, the robot stops first, no process is left behind.
The full table (every fault) is ``benchmarks/fault_injection.py``.
"""

from __future__ import annotations

import pytest

from safe_legged_c3bf.evaluation.fault_runner import run_fault
from safe_legged_c3bf.evaluation.faults import FAULTS
from safe_legged_c3bf.safety.params import FilterParams

GAIT_LAG = 0.3  # s: the gait controller's own stop after a zero command (a trot step)
DISCOVERY = 0.5  # s: a new (second) publisher is matched and seen in the graph


def _stopping_time(detection: float) -> float:
    """Detection delay + braking from the top speed at brake_decel + the gait's lag (s)."""
    p = FilterParams()
    return detection + p.max_speed / p.brake_decel + GAIT_LAG


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "detection"),
    [
        ("cmd_vel_nan_and_wall_clock_detections", None),  # reported: hit the walker
        ("obstacles_second_publisher", DISCOVERY + FilterParams().obstacles_timeout),
        ("kill_obstacle_tracker", FilterParams().obstacles_timeout),
        ("freeze_safety_filter", 0.5),  # the gait controller's command_timeout
    ],
)
def test_fault_is_handled_as_expected(tmp_path, name, detection):
    result = run_fault(name, tmp_path)
    fault = FAULTS[name]
    summary = f"{result.as_dict()}"
    assert result.collision is False, summary
    assert result.orphans == [], summary
    assert result.passed, summary
    if fault.expect == "continue":
        assert result.goal_reached and result.rejected > 0, summary
    else:
        assert result.time_to_stop is not None, summary
        assert result.time_to_stop <= _stopping_time(detection), summary
    if fault.expect == "end":
        assert result.outcome == "node_died" and fault.node in result.reason, summary
