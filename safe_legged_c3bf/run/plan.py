"""The run plan: everything decided before anything starts.

:func:`make_plan` loads the scenario once (command-line overrides applied), chooses the run
folder and writes the scenario as run to it, and gives every node its module and its
parameters (:mod:`.parameters`); the report's context comes from the same parameters.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import yaml

from safe_legged_c3bf.run.graph import RECORDER_MODULE, graph_for, node_modules
from safe_legged_c3bf.run.outcome import StartupError
from safe_legged_c3bf.run.parameters import (
    config_files,
    filter_inflation,
    merged_parameters,
    node_parameters,
)
from safe_legged_c3bf.run.quiet_stderr import quiet_stderr
from safe_legged_c3bf.run.report import RunContext
from safe_legged_c3bf.run.supervisor import NodeSpec


@dataclass
class RunPlan:
    """Everything decided before anything starts."""

    scenario: Any  # safe_legged_c3bf.sim.scenario.Scenario
    scenario_file: Path
    run_dir: Path
    specs: list[NodeSpec]
    recorder: NodeSpec | None
    context: RunContext
    remaps: list[str] = field(default_factory=list)

    def spec(self, name: str) -> NodeSpec:
        """The spec of graph node ``name``."""
        return next(s for s in self.specs if s.name == name)

    def parameters(self, name: str) -> dict[str, Any]:
        """The merged parameters of graph node ``name`` (every layer applied)."""
        return merged_parameters(self.spec(name))

    def ros_cli_args(self) -> list[str]:
        """``--ros-args -r FROM:=TO ...`` for nodes created in this process ([] if none)."""
        args = [arg for r in self.remaps for arg in ("-r", r)]
        return ["--ros-args", *args] if args else []


def _default_run_dir(name: str) -> Path:
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    run_dir = Path("runs") / f"{name}-{stamp}"
    k = 1
    while run_dir.exists():
        k += 1
        run_dir = Path("runs") / f"{name}-{stamp}-{k}"
    return run_dir


def load_scenario_once(opts: argparse.Namespace) -> tuple[dict[str, Any], Any]:
    """(mapping as run, validated Scenario): the file read once, --duration / --seed applied."""
    from safe_legged_c3bf.sim.scenario import ScenarioError, parse_scenario, resolve_scenario

    try:
        source = resolve_scenario(opts.scenario)
        try:
            raw = yaml.safe_load(source.read_text(encoding="utf-8")) or {}
        except yaml.YAMLError as err:
            raise ScenarioError(f"{source}: cannot read scenario: {err}") from None
        if not isinstance(raw, dict):
            raise ScenarioError(f"{source}: expected a YAML mapping")
        if opts.duration is not None:
            if not opts.duration > 0:
                raise StartupError("--duration must be positive")
            raw["duration"] = float(opts.duration)
        if opts.seed is not None:
            raw["seed"] = int(opts.seed)
        if getattr(opts, "perception", None) is not None:
            perception = raw.get("perception")
            raw["perception"] = {**(perception if isinstance(perception, dict) else {}),
                                 "source": opts.perception}
        raw.setdefault("name", source.stem)
        try:
            scenario = parse_scenario(raw, name=source.stem, source=str(source))
        except ScenarioError as err:
            applied = [f"--{k} {v:g}" for k, v in (("duration", opts.duration),
                                                   ("seed", opts.seed)) if v is not None]
            label = f"{source} (with {', '.join(applied)})" if applied else str(source)
            raise ScenarioError(f"{label}: {err}") from None
    except ScenarioError as err:
        raise StartupError(str(err)) from None
    except OSError as err:
        raise StartupError(f"scenario {opts.scenario}: {err}") from None
    return raw, scenario


def _check_output_files(opts: argparse.Namespace) -> None:
    if opts.video is not None and opts.video.suffix.lower() not in (".gif", ".mp4"):
        raise StartupError(f"--video {opts.video}: the file must end in .gif or .mp4")
    if opts.record is not None and opts.record.suffix.lower() != ".mcap":
        raise StartupError(f"--record {opts.record}: the file must end in .mcap")


def _check_executor(opts: argparse.Namespace) -> None:
    if getattr(opts, "executor", "events") == "multi" and not opts.in_process:
        raise StartupError("--executor multi needs --in-process (one node per process)")


def _write_scenario(run_dir: Path, raw: dict[str, Any]) -> Path:
    """Write the scenario as run to ``run_dir/scenario.yaml`` (what the nodes read)."""
    scenario_file = run_dir / "scenario.yaml"
    scenario_file.write_text(
        "# Scenario as run (overrides from the bringup command line applied).\n"
        + yaml.safe_dump(raw, sort_keys=False), encoding="utf-8",
    )
    return scenario_file


def make_plan(opts: argparse.Namespace) -> RunPlan:
    """Load the scenario, choose the run folder and the parameters of every node."""
    with quiet_stderr():
        import pybullet  # noqa: F401 - imported once, quietly, for the scenario checks

    raw, scenario = load_scenario_once(opts)
    _check_output_files(opts)
    _check_executor(opts)
    run_dir = (opts.out or _default_run_dir(scenario.name)).resolve()
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise StartupError(f"--out {run_dir}: cannot create the run folder: {err}") from None
    scenario_file = _write_scenario(run_dir, raw)
    scenario = dataclasses.replace(scenario, source=str(scenario_file))

    modules = node_modules(opts.node)
    params = node_parameters(opts, scenario, scenario_file, run_dir)
    perception = perception_source(scenario)
    specs = [
        NodeSpec(name=name, module=modules[name], parameters=params[name],
                 params_files=config_files(name, perception))
        for name in graph_for(perception)
    ]
    recorder = None
    if opts.record is not None:
        recorder = NodeSpec(name="recorder", module=RECORDER_MODULE,
                            args=[str(opts.record.resolve())])
    filter_spec = next(s for s in specs if s.name == "safety_filter")
    ctx = _context(opts, scenario, merged_parameters(filter_spec))
    for remap in opts.remap:
        if ":=" not in remap:
            raise StartupError(f"--remap {remap!r}: expected FROM:=TO")
    return RunPlan(scenario, scenario_file, run_dir, specs, recorder, ctx, list(opts.remap))


def perception_source(scenario: Any) -> str:
    """'oracle' or 'sensors': where the run's obstacle detections come from."""
    return str(getattr(scenario.perception, "source", "oracle"))


def _context(opts: argparse.Namespace, scenario: Any, filter_params: dict[str, Any]) -> RunContext:
    """The report's facts about the run, inflation sizes from the filter's parameters."""
    from safe_legged_c3bf.sim.robots import robot_spec

    width, height, margin = filter_inflation(robot_spec(scenario.robot.model), filter_params)
    return RunContext(
        scenario=scenario.name, robot=scenario.robot.kind,
        goal=tuple(scenario.goal.position), goal_tolerance=scenario.goal.tolerance,
        duration=scenario.duration, robot_width=width, robot_height=height,
        safety_margin=margin, filter_enabled=bool(filter_params.get("enabled", True)),
        mode="in-process" if opts.in_process else "processes",
        perception=perception_source(scenario),
    )
