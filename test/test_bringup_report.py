"""Run report from synthetic monitor data: summary numbers, printed text, files, re-plotting."""

from __future__ import annotations

import json

import numpy as np
import pytest

from safe_legged_c3bf.run.monitor import ObstacleTrack, RunData
from safe_legged_c3bf.run.plots import PLOTS
from safe_legged_c3bf.run.report import (
    RunContext,
    format_summary,
    main,
    summarize,
    write_run_folder,
)


def _data() -> RunData:
    d = RunData()
    t = np.arange(0.0, 10.0, 0.01)
    for k, tk in enumerate(t):
        d.odom.append((tk, 0.3 * tk, 0.0, 0.28, 0.0, 0.3, 0.0, 0.0, 0.0))
        if k % 10 == 0:
            d.cmd_vel.append((tk, 0.4, 0.0, 0.0, 0.0))
            d.cmd_vel_safe.append((tk, 0.3, 0.0, 0.0, 0.0))
    for tk in np.arange(0.0, 10.0, 0.02):  # 50 Hz filter: ACTIVE (2) for t in [4, 6)
        status = 2 if 4.0 <= tk < 6.0 else 1
        d.filter_state.append((tk, status, 0.5, 1e-4 if status == 1 else 3e-4,
                               0.4, 0, 0, 0, 0.3 if status == 2 else 0.4, 0, 0, 0))
        d.barrier.setdefault("bar", []).append((tk, 1.0 - 0.1 * tk))
    for tk in np.arange(0.0, 10.0, 0.01):  # ground truth, touching "bar" for 0.1 s at t=5
        touching = 5.0 <= tk < 5.1
        d.safety.append((tk, float(touching), float(tk >= 5.0), 0.0 if touching else
                         abs(5.0 - tk) * 0.2, 0.0))
        d.closest.append("bar")
    d.contacts.add("bar")
    d.obstacles["bar"] = ObstacleTrack("bar", 1, (0.3, 0.05), 0.0, 2.0, [0.0], [(1.5, 0.0, 0.4)])
    d.obstacles["walker"] = ObstacleTrack(
        "walker", 0, (0.2, 0.2), 0.0, 1.7, [0.0, 5.0], [(2.0, -1.0, 0.85), (2.0, 1.0, 0.85)]
    )
    d.sim_start, d.wall_start, d.sim_last, d.wall_last = 0.0, 100.0, 9.99, 120.0
    return d


def _ctx() -> RunContext:
    return RunContext(scenario="synthetic", goal=(2.8, 0.0), goal_tolerance=0.3, duration=10.0,
                      wall_time=22.0)


def test_summary_numbers():
    s = summarize(_data(), _ctx(), 9.99)
    assert s["goal"]["reached"] is True
    assert s["goal"]["time_reached"] == pytest.approx(8.34, abs=0.02)
    assert s["collision"] is True and s["collision_count"] == 1
    assert s["obstacles_touched"] == ["bar"]
    assert s["collision_time"] == pytest.approx(0.1, abs=0.011)
    assert s["min_clearance"] == 0.0 and s["min_clearance_obstacle"] == "bar"
    assert s["real_time_factor"] == pytest.approx(9.99 / 20.0)
    assert s["filter"]["intervention_share"] == pytest.approx(0.2, abs=0.01)
    assert s["filter"]["status_share"]["INACTIVE"] == pytest.approx(0.8, abs=0.01)
    assert s["filter"]["solve_time_ms"]["median"] == pytest.approx(0.1)
    assert s["filter"]["solve_time_ms"]["p99"] == pytest.approx(0.3)
    assert s["fallen"] is False
    assert s["ground_truth_source"] == "/ground_truth/safety"


def test_simulator_summary_takes_precedence():
    sim = {"collision_count": 0, "collisions": [], "time_in_collision": 0.0, "fell": True,
           "fall_time": 3.0, "min_distance": 0.05, "min_distance_time": 5.0,
           "min_distance_obstacle": "bar", "sim_time": 10.0}
    s = summarize(_data(), _ctx(), 9.99, sim)
    assert s["collision"] is False and s["fallen"] is True and s["min_clearance"] == 0.05
    assert s["sim_time"] == 10.0
    assert s["ground_truth_source"].startswith("simulator")


def test_printed_summary():
    text = format_summary(summarize(_data(), _ctx(), 9.99))
    assert text.startswith("Run COMPLETED")
    assert "goal reached      yes (at t = 8.3 s" in text
    assert "collision         YES (1 event(s); touched bar)" in text
    assert "min clearance     0.000 m (to bar" in text
    assert "filter intervened 20.0 % of the time (500 cycles)" in text
    assert "filter solve time median 0.100 ms, p99 0.300 ms" in text


def test_empty_run_still_reports():
    ctx = _ctx()
    ctx.outcome, ctx.reason = "startup_failed", "no message from the simulator"
    s = summarize(RunData(), ctx, None)
    assert s["collision"] is None and s["goal"]["reached"] is False
    text = format_summary(s)
    assert "Run STARTUP_FAILED: no message from the simulator" in text
    assert "unknown (no ground truth received)" in text


def test_run_folder_files_and_replot(tmp_path):
    report = write_run_folder(tmp_path, _data(), _ctx(), 9.99, {"exit_code": 0})
    assert "plot_error" not in report
    assert set(report["files"]) == {"timeseries.npz", *PLOTS.values()}  # side view: a bar
    for name in report["files"]:
        assert (tmp_path / name).stat().st_size > 1000
    on_disk = json.loads((tmp_path / "report.json").read_text())
    assert on_disk["summary"]["collision"] is True and on_disk["exit_code"] == 0
    for name in PLOTS.values():
        (tmp_path / name).unlink()
    assert main([str(tmp_path)]) == 0
    assert all((tmp_path / name).is_file() for name in PLOTS.values())


def test_outcome_settles_after_the_first_decisive_event():
    from types import SimpleNamespace

    from safe_legged_c3bf.run.monitor import MonitorNode

    def decided(t, goal=None, collision=None, fall=None):
        m = SimpleNamespace(sim_time=t, goal_time=goal, collision_time=collision, fall_time=fall)
        return MonitorNode.decided(m, 1.0)

    assert decided(None) is None
    assert decided(10.0) is None
    assert decided(10.5, goal=10.0) is None  # still within the hold time
    assert decided(11.0, goal=10.0).startswith("goal reached at t = 10.00 s")
    # A collision names the run even when the goal came first.
    assert decided(12.0, goal=10.0, collision=10.5).startswith("collision at t = 10.50 s")
    assert decided(12.0, fall=9.0).startswith("fall at t = 9.00 s")


def test_runs_end_on_their_outcome_unless_full_duration():
    from safe_legged_c3bf.bringup import build_parser

    assert build_parser().parse_args([]).stop_on_outcome is True
    assert build_parser().parse_args(["--full-duration"]).stop_on_outcome is False
    assert build_parser().parse_args(["--stop-on-outcome"]).stop_on_outcome is True


def test_cpu_per_node_is_reported_per_sim_second():
    ctx = RunContext(scenario="s", duration=10.0, wall_time=20.0,
                     cpu_seconds={"simulator": 6.0, "gait_controller": 4.0, "bringup": 1.0})
    s = summarize(_data(), ctx, 10.0)
    cpu = s["cpu"]
    assert cpu["per_sim_second"] == {"bringup": 0.1, "gait_controller": 0.4, "simulator": 0.6}
    assert cpu["total_per_sim_second"] == pytest.approx(1.1)
    assert cpu["cores"] == pytest.approx(11.0 / 20.0)
    text = format_summary(s)
    assert "cpu               1.10 core-s per sim s (simulator 0.60, gait_controller 0.40" in text
    # unknown CPU (no node processes measured) reads n/a, not zero
    empty = summarize(_data(), RunContext(scenario="s", duration=10.0, wall_time=1.0), 10.0)
    assert empty["cpu"]["total_per_sim_second"] is None and empty["cpu"]["cores"] is None
    assert "cpu               n/a" in format_summary(empty)


def test_cpu_meter_keeps_the_last_value_of_an_exited_process():
    import subprocess
    import sys

    from safe_legged_c3bf.run.cpu_usage import CpuMeter, own_cpu_seconds, process_cpu_seconds

    busy = subprocess.Popen([sys.executable, "-c", "import time\nt=time.process_time()\n"
                             "while time.process_time() - t < 0.3: pass\ninput()"],
                            stdin=subprocess.PIPE)
    meter = CpuMeter()
    try:
        for _ in range(200):
            meter.sample({"busy": busy.pid})
            if meter.seconds.get("busy", 0.0) >= 0.3:
                break
            subprocess.run(["sleep", "0.05"], check=True)
    finally:
        busy.communicate(b"\n", timeout=10)
    assert meter.seconds["busy"] >= 0.3
    last = meter.seconds["busy"]
    meter.sample({"busy": busy.pid})  # reaped: /proc has nothing, the value stays
    assert meter.seconds["busy"] == last
    assert process_cpu_seconds(busy.pid) is None
    assert own_cpu_seconds() > 0.0
