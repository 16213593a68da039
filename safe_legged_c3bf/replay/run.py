"""Replay a recording into the safety pipeline, in this process, and score the filter.

The pipeline is the deployment's (:mod:`safe_legged_c3bf.run.deploy`: obstacle detector,
tracker and filter, the robot profile's parameters, no simulator) on sim time from the
recording's ``/clock``, on a private ROS domain. The recording's own ``/obstacles``,
``/obstacles/detections`` and ``/cmd_vel_safe`` are not played: the pipeline makes them anew.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from safe_legged_c3bf.replay.kpis import FilterCycles, KpiLimits, KpiReport, score
from safe_legged_c3bf.replay.recording import Recording, load_recording

#: Sim s the pipeline keeps running after the last played message (its last outputs).
DRAIN_SIM = 0.5


@dataclass
class ReplayResult:
    """A replay's cycles, scores and facts."""

    recording: Recording
    cycles: FilterCycles
    report: KpiReport
    wall_time: float
    pad: float


def pipeline_opts(robot: str, params_files: list[Path] | None = None) -> argparse.Namespace:
    """The deployment options of a replay: the robot's pipeline on sim time, no planner."""
    return argparse.Namespace(robot=robot, with_planner=False, use_sim_time=True, remap=[],
                              params_file=list(params_files or []), node=[])


def pipeline_parameters(
    robot: str, params_files: list[Path] | None = None
) -> tuple[list[Any], dict[str, dict[str, Any]]]:
    """The pipeline's node specs and what each node ends up with, ``params_files`` last."""
    from safe_legged_c3bf.run.deploy import deploy_specs
    from safe_legged_c3bf.run.parameters import merged_parameters

    specs = deploy_specs(pipeline_opts(robot, params_files))
    return specs, {s.name: merged_parameters(s, params_files or []) for s in specs}


def filter_pad(robot: str, filter_params: dict[str, Any]) -> float:
    """The filter's growth of a vertical obstacle's radius: half the width plus the margin (m)."""
    from safe_legged_c3bf.run.parameters import filter_inflation
    from safe_legged_c3bf.sim.robots import robot_spec

    width, _height, margin = filter_inflation(robot_spec(robot), filter_params)
    return 0.5 * width + margin


def replay(path: str | Path, robot: str = "quadruped", rate: float = 1.0,
           params_files: list[Path] | None = None,
           limits: KpiLimits | None = None) -> ReplayResult:
    """Play ``path`` into a fresh pipeline and score it (rclpy must not be initialised)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from safe_legged_c3bf.replay.player import FilterCollector, RecordingPlayer
    from safe_legged_c3bf.run.in_process import find_node_class, rclpy_parameters

    recording = load_recording(path)
    specs, merged = pipeline_parameters(robot, params_files)
    pad = filter_pad(robot, merged["safety_filter"])
    context = rclpy.Context()
    rclpy.init(context=context)
    nodes = []
    executor = SingleThreadedExecutor(context=context)
    wall0 = time.monotonic()
    try:
        collector = FilterCollector(context=context)
        nodes.append(collector)
        for spec in specs:
            cls = find_node_class(spec.module)
            nodes.append(cls(parameter_overrides=rclpy_parameters(merged[spec.name]),
                             context=context))
        player = RecordingPlayer(recording, rate, context=context)
        nodes.append(player)
        for node in nodes:
            executor.add_node(node)
        end = None
        while end is None or time.monotonic() < end:
            executor.spin_once(timeout_sec=0.01)
            if end is None and player.finished:
                end = time.monotonic() + DRAIN_SIM / rate
        cycles = collector.cycles()
    finally:
        for node in reversed(nodes):
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)
    report = score(cycles, recording.truth, pad, limits)
    return ReplayResult(recording, cycles, report, time.monotonic() - wall0, pad)
