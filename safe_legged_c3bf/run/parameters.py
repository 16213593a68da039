"""Node parameters of a run, layer on layer, merged in one place.

The layers, lowest first:

1. the node's config file, ``config/<node>.yaml`` (given to the node as a parameter file),
   then, when the obstacles come from the detector, ``config/sensors/<node>.yaml``;
2. what the bringup sets from its command line and the run folder (the scenario file as run,
   ``gui``, ``lockstep``, ``enabled`` for the filter, ``robot`` for the gait controller, ...);
3. the robot profile, ``config/robots/<kind>.yaml``;
4. the scenario's ``filter:``, ``tracker:`` and ``controller:`` override sections;
5. ``--no-filter``, which always wins.

:func:`node_parameters` builds layers 2-5 (a node's overrides, written to its second
parameter file); :func:`merged_parameters` adds layer 1: what the node ends up with, which the
in-process nodes are given and the report's inflation sizes are read from.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import yaml

from safe_legged_c3bf.run.graph import NODE_NAMES
from safe_legged_c3bf.run.outcome import StartupError
from safe_legged_c3bf.run.supervisor import NodeSpec

#: Scenario override sections -> node names.
OVERRIDE_TARGETS = {
    "filter": "safety_filter", "tracker": "obstacle_tracker", "controller": "gait_controller",
    "detector": "obstacle_detector",
}


def config_files(node_name: str, perception: str = "oracle") -> list[Path]:
    """The node's own config files (layer 1) the package has, lowest first.

    ``config/<node>.yaml``, then with ``perception`` 'sensors' (the obstacle detector's
    output, in simulation or on a robot) ``config/sensors/<node>.yaml``.
    """
    from safe_legged_c3bf.run.config import config_path

    names = [(f"{node_name}.yaml",)]
    if perception == "sensors":
        names.append(("sensors", f"{node_name}.yaml"))
    files = []
    for parts in names:
        try:
            path = config_path(*parts)
        except FileNotFoundError:
            continue
        if path.is_file():
            files.append(path)
    return files


def robot_profile(kind: str) -> dict[str, dict[str, Any]]:
    """Per-robot node parameters from config/robots/<kind>.yaml (node name -> values)."""
    from safe_legged_c3bf.run.config import config_path, load_yaml

    kind = "quadruped" if kind == "a1" else kind
    try:
        profile = load_yaml(config_path("robots", f"{kind}.yaml"))
    except FileNotFoundError:
        return {}
    for node_name, values in profile.items():
        if node_name not in NODE_NAMES or not isinstance(values, dict):
            raise StartupError(
                f"config/robots/{kind}.yaml: '{node_name}' must be one of "
                f"{sorted(NODE_NAMES)} with a mapping of parameters"
            )
    return profile


def _bringup_layer(
    opts: argparse.Namespace, robot_kind: str, scenario_file: Path, run_dir: Path
) -> dict[str, dict[str, Any]]:
    """Layer 2: what the bringup sets from its command line and the run folder."""
    params: dict[str, dict[str, Any]] = {name: {} for name in NODE_NAMES}
    sim = params["simulator"]
    sim.update(scenario=str(scenario_file), gui=bool(opts.gui),
               summary_path=str(run_dir / "simulator_summary.json"))
    sim["lockstep"] = bool(opts.lockstep)
    if opts.real_time_factor is not None:
        if not opts.real_time_factor >= 0:
            raise StartupError("--real-time-factor must be >= 0")
        sim["real_time_factor"] = float(opts.real_time_factor)
    if not opts.in_process:
        # The simulator process exits 0 when the scenario ends; in-process, the bringup polls
        # SimulatorNode.finished instead (shutting the shared context down would stop all).
        sim["exit_on_finish"] = True
    if opts.video is not None:
        sim.update(video_path=str(opts.video.resolve()), video_fps=float(opts.video_fps))
    params["reference_planner"]["scenario"] = str(scenario_file)  # goal + planner section
    params["safety_filter"]["enabled"] = not opts.no_filter
    params["gait_controller"]["robot"] = robot_kind
    params["obstacle_detector"]["robot_kind"] = robot_kind  # the sensors' mounts
    params["obstacle_tracker"]["robot_kind"] = robot_kind  # the LiDAR's (scan_clearing)
    # the recorder also reads /joint_commands: hold physics until it has matched
    recording = getattr(opts, "record", None) is not None
    params["gait_controller"]["start_subscribers"] = 2 if recording else 1
    return params


def node_parameters(
    opts: argparse.Namespace, scenario: Any, scenario_file: Path, run_dir: Path
) -> dict[str, dict[str, Any]]:
    """Every node's parameter overrides: layers 2 to 5, later layers winning."""
    params = _bringup_layer(opts, scenario.robot.kind, scenario_file, run_dir)
    for node_name, values in robot_profile(scenario.robot.kind).items():
        params[node_name].update(values)
    for section, values in scenario.overrides.items():
        target = OVERRIDE_TARGETS.get(section)
        if target:
            params[target].update(values)
    if opts.no_filter:
        params["safety_filter"]["enabled"] = False
    return params


def merged_parameters(spec: NodeSpec, last_files: Iterable[Path] = ()) -> dict[str, Any]:
    """What a node ends up with: its config files, its overrides, then ``last_files``.

    ``last_files`` are the user's ``--params-file`` files of a pipeline built in this process
    (a node process reads them itself from its ``--ros-args``).
    """
    merged: dict[str, Any] = {}
    for path in spec.params_files:
        merged.update(_file_section(path, spec.name))
    merged.update(spec.parameters)
    for path in last_files:
        merged.update(_file_section(path, spec.name))
    return merged


def _file_section(path: Path, node_name: str) -> dict[str, Any]:
    """The ``ros__parameters`` a ROS 2 parameter file gives node ``node_name``."""
    data = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
    values: dict[str, Any] = {}
    for key, section in data.items():
        if isinstance(section, dict) and key in (node_name, f"/{node_name}", "/**"):
            values.update(section.get("ros__parameters", {}) or {})
    return values


def filter_inflation(robot: Any, filter_params: dict[str, Any]) -> tuple[float, float, float]:
    """Robot width, height and safety margin the filter inflates obstacles with.

    The filter's defaults, then its merged parameters (``filter_params``); the simulator's
    robot description (``robot``) when the filter's parameters cannot be read.
    """
    values: dict[str, Any] = {"robot_width": robot.width, "robot_height": robot.height,
                              "safety_margin": 0.0}
    try:
        from safe_legged_c3bf.safety.params import FilterParams

        defaults = asdict(FilterParams())
        values.update({k: defaults[k] for k in values if k in defaults})
    except (ImportError, TypeError, ValueError):
        pass
    try:
        return tuple(float(filter_params.get(k, values[k])) for k in values)  # type: ignore[return-value]
    except (TypeError, ValueError):
        return tuple(float(v) for v in values.values())  # type: ignore[return-value]
