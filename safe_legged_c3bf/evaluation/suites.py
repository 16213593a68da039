"""The evaluation suites and the runs they consist of.

A suite (``paper``, ``named``, ``random-quadruped``, ``random-biped``, ``all``, ``ci``; see
:mod:`safe_legged_c3bf.evaluate`) is a list of :class:`Case` (one scenario and seed);
:func:`plan_runs` splits each into the runs of the evaluation: with the filter, without it,
and with the filter on the same scenario without obstacles; with ``--compare-body-models``
the filter run is replaced by one per :data:`BODY_MODELS` value (the same scenario and seed
with ``filter.body_model`` set). Random scenarios, the obstacle-free and the body-model
variants are written as YAML under ``<out>/scenarios/``. Durations in s of sim
time.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from safe_legged_c3bf.evaluation.runner import RunSpec
from safe_legged_c3bf.sim.scenario_sections import (
    PERCEPTION_SOURCES as SCENARIO_PERCEPTION_SOURCES,
)

#: Evaluation scenarios in config/scenarios: name -> kind (robot comes from the file).
PAPER_SCENARIOS = {
    "quadruped_static": "static",
    "quadruped_moving": "moving",
    "quadruped_horizontal": "horizontal",
    "biped_static": "static",
    "biped_moving": "moving",
}
NAMED_SCENARIOS = PAPER_SCENARIOS | {
    "quadruped_multi": "multi",
    "quadruped_head_on": "head_on",
    "quadruped_crossing": "crossing",
    "quadruped_bar_and_pillar": "bar_and_pillar",
    # Issue #16: what a single body point misses (doc/evaluation.md, Scenarios).
    "quadruped_low_bar": "impassable",
    "biped_low_bar": "impassable",
    "quadruped_bar_rising": "bar_rising",
    "quadruped_gap": "gap",
    "quadruped_wall": "wall",
    "quadruped_crowd": "crowd",
    "biped_crowd": "crowd",
    # Issue #17: getting past a slower mover ahead (doc/evaluation.md, Scenarios).
    "quadruped_overtake_cart": "overtake",
    "biped_overtake_walker": "overtake",
    "quadruped_corridor_walker": "overtake",
    # Issue #17: leaving a standstill in front of static obstacles.
    "quadruped_symmetric_pillar": "deadlock",
    "biped_symmetric_pillar": "deadlock",
    "quadruped_corner": "deadlock",
    "biped_corner": "deadlock",
}
#: Named scenarios whose straight path clears every obstacle (the unfiltered robot passes
#: untouched): they test that the filter does not block what the body fits past.
CLEAR_PATH_SCENARIOS = frozenset({"quadruped_wall"})
CI_SCENARIO = "quadruped_ci"
#: The safety filter settings compared by ``--compare-body-models`` (name -> the filter
#: overrides it sets): the paper's single body point, the whole body, and the whole body that
#: may also side-step (``model: unicycle_lateral``, issue #17).
FILTER_VARIANTS = {
    "point": {"body_model": "point", "model": "unicycle"},
    "body": {"body_model": "body", "model": "unicycle"},
    "body_lateral": {"body_model": "body", "model": "unicycle_lateral"},
}
BODY_MODELS = tuple(FILTER_VARIANTS)
SUITES = ("paper", "named", "random-quadruped", "random-biped", "all", "ci")
DEFAULT_RANDOM_SEEDS = 5


@dataclass
class Case:
    """One scenario (and seed) of a suite, before it is split into runs."""

    case: str
    scenario: str  # name or path
    robot: str
    kind: str
    duration: float
    raw: dict[str, Any]  # the scenario mapping (to derive the obstacle-free variant)
    seed: int | None = None
    baseline: bool = True  # also run without the filter
    free: bool = True  # also run without obstacles


def _load_raw(name_or_path: str) -> tuple[Path, dict[str, Any]]:
    from safe_legged_c3bf.sim.scenario import load_scenario, resolve_scenario

    path = resolve_scenario(name_or_path)
    load_scenario(path)  # validate (ScenarioError names the field)
    raw = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    raw.setdefault("name", path.stem)
    return path, raw


def _named_cases(items: dict[str, str], seeds: int | None) -> list[Case]:
    """Cases of scenarios given by name or path (-> kind), ``seeds`` perception seeds each."""
    cases = []
    for item, kind in items.items():
        path, raw = _load_raw(item)
        name = str(raw.get("name", path.stem))
        robot = _robot_kind(raw)
        duration = float(raw.get("duration", 30.0))
        if not seeds or seeds <= 1:
            cases.append(Case(name, item, robot, kind, duration, raw))
            continue
        base = int(raw.get("seed", 0))
        for k in range(seeds):
            cases.append(Case(f"{name}@seed{base + k}", item, robot, kind, duration, raw,
                              seed=base + k))
    names = [c.case for c in cases]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        from safe_legged_c3bf.sim.scenario import ScenarioError

        raise ScenarioError(f"scenario names given twice: {', '.join(duplicates)}")
    return cases


def _robot_kind(raw: dict[str, Any]) -> str:
    from safe_legged_c3bf.sim.scenario import parse_scenario

    return parse_scenario(raw, name=str(raw.get("name", "scenario"))).robot.kind


def _random_cases(robot: str, seeds: int, start: int, out: Path) -> list[Case]:
    from safe_legged_c3bf.evaluation import random_scenario as rs

    cases = []
    for seed in range(start, start + seeds):
        data = rs.generate_scenario(robot, seed)
        path = rs.write_scenario(out / "scenarios" / f"{data['name']}.yaml", data)
        cases.append(Case(data["name"], str(path), robot, f"random_{robot}",
                          float(data["duration"]), data))
    return cases


def plan_cases(opts: argparse.Namespace, out: Path) -> list[Case]:
    """The cases of the requested suite (or --scenario list)."""
    if opts.scenario:
        items = {}
        for item in opts.scenario:
            stem = Path(item).stem if item.endswith((".yaml", ".yml")) else item
            items[item] = (NAMED_SCENARIOS | {CI_SCENARIO: "static"}).get(stem, "custom")
        return _named_cases(items, opts.seeds)
    suite = opts.suite
    n_random = opts.seeds if opts.seeds is not None else DEFAULT_RANDOM_SEEDS
    if suite == "ci":
        path, raw = _load_raw(CI_SCENARIO)
        return [Case(CI_SCENARIO, CI_SCENARIO, _robot_kind(raw), "static",
                     float(raw.get("duration", 15.0)), raw, baseline=False, free=False)]
    if suite == "paper":
        return _named_cases(PAPER_SCENARIOS, opts.seeds)
    if suite == "named":
        return _named_cases(NAMED_SCENARIOS, opts.seeds)
    if suite == "random-quadruped":
        return _random_cases("quadruped", n_random, opts.seed_start, out)
    if suite == "random-biped":
        return _random_cases("biped", n_random, opts.seed_start, out)
    # all
    return (_named_cases(NAMED_SCENARIOS, None)
            + _random_cases("quadruped", n_random, opts.seed_start, out)
            + _random_cases("biped", n_random, opts.seed_start, out))


def write_body_model_variant(raw: dict[str, Any], model: str, path: Path) -> Path:
    """Write ``raw`` with variant ``model``'s filter overrides to ``path``; return the path.

    ``model``: a key of :data:`FILTER_VARIANTS`; the file is YAML.

    Not validated here: the base scenario was, and the keys are the safety filter's
    parameters, which the bringup validates against the installed filter
    (``evaluate --compare-body-models`` refuses to run without ``body_model``).
    """
    from safe_legged_c3bf.evaluation import random_scenario as rs

    data = dict(raw)
    data["filter"] = {**(raw.get("filter") or {}), **FILTER_VARIANTS[model]}
    data["name"] = f"{raw.get('name', path.stem)}__{model}"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(rs.scenario_yaml(data), encoding="utf-8")
    return path


def body_model_supported() -> bool:
    """True when the installed safety filter declares the ``body_model`` parameter."""
    from safe_legged_c3bf.safety.params import FilterParams

    return "body_model" in getattr(FilterParams, "__dataclass_fields__", {})


#: Perception sources compared by ``--compare-perception``: every source of the scenario format.
PERCEPTION_SOURCES = SCENARIO_PERCEPTION_SOURCES


def plan_runs(cases: list[Case], opts: argparse.Namespace, out: Path, suite: str) -> list:
    """RunSpecs (filter on, filter off, obstacle-free) of every case, in run order."""
    from safe_legged_c3bf.evaluation import random_scenario as rs

    specs: list[RunSpec] = []
    for c in cases:
        common = dict(case=c.case, robot=c.robot, kind=c.kind, suite=suite, seed=c.seed,
                      duration=opts.duration)
        perception = getattr(opts, "perception", None) or ""
        common["perception"] = perception
        if getattr(opts, "compare_perception", False):
            for source in PERCEPTION_SOURCES:
                specs.append(RunSpec(run_id=f"{c.case}__{source}", scenario=c.scenario,
                                     filter_enabled=True, **{**common, "perception": source}))
        elif getattr(opts, "compare_body_models", None) is not None:
            for model in opts.compare_body_models or BODY_MODELS:
                path = write_body_model_variant(c.raw, model, out / "scenarios" / (
                    f"{c.case.replace('@', '_')}__{model}.yaml"))
                specs.append(RunSpec(run_id=f"{c.case}__{model}", scenario=str(path),
                                     filter_enabled=True, body_model=model, **common))
        else:
            specs.append(RunSpec(run_id=f"{c.case}__filter", scenario=c.scenario,
                                 filter_enabled=True, **common))
        if c.baseline and not opts.no_baseline:
            specs.append(RunSpec(run_id=f"{c.case}__nofilter", scenario=c.scenario,
                                 filter_enabled=False, **common))
        if c.free and not opts.no_free:
            free = rs.without_obstacles(c.raw)
            path = rs.write_scenario(out / "scenarios" / f"{free['name']}.yaml", free)
            specs.append(RunSpec(run_id=f"{c.case}__free", scenario=str(path),
                                 filter_enabled=True, variant="free", **common))
    return specs
