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
from safe_legged_c3bf.perception.params import ObstacleTrackerParams
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
        ("scan_wall_clock", None),  # sensor perception: a phantom ring on a foreign clock
        # no detections -> the tracker stops /obstacles -> the filter's input goes stale
        ("kill_obstacle_detector",
         ObstacleTrackerParams().detections_timeout + FilterParams().obstacles_timeout),
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


def test_sensor_fault_payloads_are_what_their_names_say():
    """The phantom scan and cloud decode; the truncated cloud does not; no returns are NaN."""
    import math

    from sensor_msgs.msg import LaserScan, PointCloud2

    from safe_legged_c3bf.evaluation.fault_injector import _fill
    from safe_legged_c3bf.nodes.messages import laser_scan_points, point_cloud_xyz
    from safe_legged_c3bf.perception.sensor_points import SensorInputError

    scan = LaserScan()
    _fill("scan_phantom", scan)
    assert len(laser_scan_points(scan).points) == 360
    _fill("scan_no_returns", scan)
    assert all(math.isnan(r) for r in scan.ranges)
    assert len(laser_scan_points(scan).points) == 0
    cloud = PointCloud2()
    _fill("points_phantom", cloud)
    assert point_cloud_xyz(cloud).shape == (600, 3)
    _fill("points_truncated", cloud)
    with pytest.raises(SensorInputError):
        point_cloud_xyz(cloud)
    for fault in FAULTS.values():  # every sensor fault runs the sensor graph
        if fault.topic in ("/scan", "/points") or fault.node == "obstacle_detector":
            assert fault.perception == "sensors", fault.name
