"""The safety pipeline alone, on a real robot's topics: ``bringup --deploy``.

Starts the obstacle detector, obstacle tracker and safety filter (and, with
``--with-planner``, the reference planner), each in its own supervised process (``--deploy``
does not compose them in one), with the robot profile's parameters, on the environment's ROS
domain (a real robot's graph is not private), on the system clock (``--use-sim-time`` for a
replay with /clock). No simulator and no gait controller: the robot's own driver reads
``/cmd_vel_safe``; remappings connect the pipeline to the driver's topic names
(doc/deploy.md).

It runs until SIGINT / SIGTERM (exit 0). A node that dies is reported at once and the others
keep running: without fresh obstacles or odometry the filter brakes to a stop on its input
timeouts, and without the filter nothing reaches ``/cmd_vel_safe`` (the driver's command
timeout stops the robot). The exit code is then 1.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

from safe_legged_c3bf.run.console import StopRequest
from safe_legged_c3bf.run.graph import graph_for, node_modules
from safe_legged_c3bf.run.outcome import EXIT_FAILED, EXIT_OK, StartupError
from safe_legged_c3bf.run.parameters import config_files, robot_profile
from safe_legged_c3bf.run.supervisor import NodeSpec, Supervisor, describe_returncode

ROBOT_KINDS = ("quadruped", "biped")


def deploy_specs(opts: argparse.Namespace) -> list[NodeSpec]:
    """The pipeline's nodes with their parameters: config file, robot profile, user files.

    Layers, lowest first: ``config/<node>.yaml``, ``config/robots/<robot>.yaml``, what the
    deployment sets (the detector's robot, ``use_sim_time``), then each ``--params-file``
    (ROS 2 parameter files: ``node_name: {ros__parameters: {...}}``), which wins.
    """
    if opts.robot not in ROBOT_KINDS:
        raise StartupError(f"--robot {opts.robot!r}: expected one of {', '.join(ROBOT_KINDS)}")
    for path in opts.params_file:
        if not Path(path).is_file():
            raise StartupError(f"--params-file {path}: no such file")
    names = graph_for("sensors", deploy=True, planner=opts.with_planner)
    modules = node_modules(opts.node)
    profile = robot_profile(opts.robot)
    specs = []
    for name in names:
        params: dict[str, Any] = dict(profile.get(name, {}))
        params["use_sim_time"] = bool(opts.use_sim_time)
        if name in ("obstacle_detector", "obstacle_tracker"):
            params["robot_kind"] = opts.robot  # the sensors' default mounts
        specs.append(NodeSpec(
            name=name, module=modules[name], parameters=params,
            params_files=config_files(name, "sensors"),
            ros_args=[*(a for r in opts.remap for a in ("-r", r)),
                      *(a for f in opts.params_file for a in ("--params-file", str(f)))],
        ))
    return specs


def run_deploy(opts: argparse.Namespace, run_dir: Path) -> int:
    """Start the pipeline's processes and keep them until a signal; return the exit code."""
    specs = deploy_specs(opts)
    missing = [f"{s.name} ({s.module})" for s in specs if not s.module_available()]
    if missing:
        raise StartupError("node module(s) not installed: " + ", ".join(missing))
    signals = StopRequest()  # SIGINT, SIGTERM and SIGHUP stop the pipeline in order
    supervisor = Supervisor(run_dir / "logs", env=dict(os.environ))
    failed: list[str] = []
    try:
        for spec in specs:
            supervisor.start(spec)
        print(f"deploy: {', '.join(s.name for s in specs)} running ({opts.robot}); "
              f"logs in {run_dir / 'logs'}; Ctrl-C stops", flush=True)
        while not signals:
            time.sleep(0.2)
            for proc in supervisor.newly_exited():
                line = f"node {proc.name} (pid {proc.pid}) {describe_returncode(proc.poll())}"
                failed.append(line)
                print(f"deploy: {line}; the others keep running (the filter brakes on stale "
                      "inputs)", file=sys.stderr, flush=True)
                for text in proc.last_lines():
                    print(f"  [{proc.name}] {text}", file=sys.stderr)
    finally:
        supervisor.stop(supervisor.running(), deadline=time.monotonic() + 4.5)
        signals.restore()
    return EXIT_FAILED if failed else EXIT_OK

