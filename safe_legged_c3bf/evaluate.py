"""Scenario suites with and without the safety filter: ``python -m safe_legged_c3bf.evaluate``.

Every scenario of a suite runs three times through the bringup (each run its own process
group and private ROS domain, ``--jobs`` at a time): with the filter, without it
(``--no-filter``: does the scenario really threaten a collision?) and with the filter on the
same scenario without obstacles (the reference for the time-to-goal overhead). The results
(one row per run, classified: ok, collided, fell, goal_not_reached, node_died, ...) are
aggregated per robot, per scenario kind and per scenario into ``results.md``, ``results.csv``,
``summary.csv`` and ``figures/`` in ``--out``.

Suites: ``paper`` (the paper's five experiments), ``named`` (every evaluation scenario in
config/scenarios), ``random-quadruped`` / ``random-biped`` (``--seeds`` random scenarios from
:mod:`safe_legged_c3bf.evaluation.random_scenario`), ``all`` (named and both random suites),
``ci`` (one short quadruped run with the filter only).

Campaigns are resumable: every finished run saves its row in its run folder as it ends, and
the same command on the same ``--out`` continues with the runs not finished yet
(:mod:`safe_legged_c3bf.evaluation.campaign_state`). ``--ray [ADDRESS]`` runs every run as a
Ray task, on a Ray started here or on a cluster (:mod:`safe_legged_c3bf.evaluation.ray_pool`;
needs ``pip install '.[cluster]'``); without it a local pool runs ``--jobs`` at a time.

Exit codes: 0 every run was executed (collisions, falls and dead nodes are results, in the
tables); 1 some run could not be executed (start-up failure, no report) or nothing ran;
2 bad arguments; 130 / 143 interrupted (the tables of the finished runs are still written).
See doc/evaluation.md.
"""

from __future__ import annotations

import argparse
import math
import sys
from datetime import datetime
from pathlib import Path
from typing import Any

from safe_legged_c3bf.evaluation.campaign import CampaignResult, run_campaign
from safe_legged_c3bf.evaluation.campaign_state import CampaignMismatchError, CampaignState
from safe_legged_c3bf.evaluation.metrics import attach_overhead
from safe_legged_c3bf.evaluation.results import write_results as _write_results
from safe_legged_c3bf.evaluation.runner import Runner, RunSpec
from safe_legged_c3bf.evaluation.suites import (
    BODY_MODELS,
    CI_SCENARIO,
    DEFAULT_RANDOM_SEEDS,
    NAMED_SCENARIOS,
    PAPER_SCENARIOS,
    PERCEPTION_SOURCES,
    SUITES,
    Case,
    body_model_supported,
    plan_cases,
    plan_runs,
)
from safe_legged_c3bf.run.quiet_stderr import quiet_stderr

__all__ = [  # the suites and their planning are re-exported from evaluation.suites
    "CI_SCENARIO", "DEFAULT_RANDOM_SEEDS", "EXIT_FAILED", "EXIT_OK", "EXIT_USAGE",
    "NAMED_SCENARIOS", "PAPER_SCENARIOS", "SUITES", "Case", "build_parser", "combine", "main",
    "plan_cases", "plan_runs",
]

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


def build_parser() -> argparse.ArgumentParser:
    """The command line."""
    p = argparse.ArgumentParser(
        prog="python -m safe_legged_c3bf.evaluate",
        description="Run scenario suites with and without the C3BF safety filter and "
        "tabulate collisions, goals, clearances, overheads and solve times.",
        epilog="Exit codes: 0 all runs executed (failures are in the tables), 1 some run "
        "could not be executed, 2 bad arguments, 130/143 interrupted. See doc/evaluation.md.",
    )
    p.add_argument("--suite", choices=SUITES, default="paper",
                   help="which scenarios (default paper)")
    p.add_argument("--scenario", action="append", default=[], metavar="NAME|PATH",
                   help="run this scenario instead of a suite (repeatable)")
    p.add_argument("--seeds", type=int, metavar="N",
                   help=f"random suites: number of random scenarios (default "
                   f"{DEFAULT_RANDOM_SEEDS}); named scenarios: perception seeds per scenario "
                   "(default 1: the scenario's own seed)")
    p.add_argument("--seed-start", type=int, default=0, metavar="S",
                   help="first random-scenario seed (default 0)")
    p.add_argument("--jobs", "-j", type=int, default=2, metavar="N",
                   help="bringups at once (default 2; each is 5-6 busy processes)")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="output folder (default runs/evaluation-<suite>-<timestamp>)")
    p.add_argument("--in-process", action="store_true",
                   help="run each bringup with --in-process (all nodes in one process)")
    p.add_argument("--full-duration", action="store_true",
                   help="run every scenario to its end (default: stop a run once its outcome "
                   "is settled: 1 s after the goal, the first collision or a fall)")
    p.add_argument("--no-baseline", action="store_true", help="skip the runs without filter")
    p.add_argument("--no-free", action="store_true",
                   help="skip the obstacle-free reference runs (no time-to-goal overhead)")
    p.add_argument("--compare-body-models", nargs="*", choices=BODY_MODELS, metavar="MODEL",
                   help="run the filter once per body model on the same scenarios and "
                   "seeds, and tabulate them side by side: point (the paper's single body "
                   "point), body (the whole body) and body_lateral (the whole body with "
                   "model: unicycle_lateral, which may also side-step); all three, or the "
                   "MODELs named")
    p.add_argument("--perception", choices=PERCEPTION_SOURCES,
                   help="every run's perception: the simulator's oracle detections or the "
                   "obstacle detector on simulated sensors (default: each scenario's own)")
    p.add_argument("--compare-perception", action="store_true",
                   help="run the filter once per perception source (oracle, sensors) on the "
                   "same scenarios and seeds, and tabulate them side by side")
    p.add_argument("--duration", type=float, metavar="S",
                   help="override every scenario's duration (sim seconds)")
    p.add_argument("--combine", nargs="+", type=Path, metavar="DIR",
                   help="run nothing: merge the results.csv of these evaluation folders into "
                   "one set of tables and figures in --out (e.g. the two random suites)")
    p.add_argument("--restart", action="store_true",
                   help="run every run again, even those --out already finished (default: "
                   "continue the campaign in --out, running only what is not finished)")
    ray = p.add_argument_group("Ray (pip install '.[cluster]')")
    ray.add_argument("--ray", nargs="?", const="local", metavar="ADDRESS",
                     help="run every run as a Ray task: on a Ray started here (no ADDRESS), "
                     "or on a cluster ('auto', host:port or ray://host:10001); --jobs is "
                     "then ignored, Ray runs as many as the CPUs allow")
    ray.add_argument("--ray-cpus", type=float, default=2.0, metavar="N",
                     help="CPUs each run reserves (default 2)")
    ray.add_argument("--ray-memory", type=float, metavar="GB",
                     help="memory each run reserves (GiB; default none; a run peaks at ~1 GiB)")
    ray.add_argument("--shared-dir", type=Path, metavar="DIR",
                     help="a folder every Ray node mounts at the same path: runs write their "
                     "folders to DIR/runs/ there instead of sending them back to --out")
    p.add_argument("--dry-run", action="store_true", help="list the runs and exit")
    p.add_argument("--no-figures", action="store_true", help="tables only")
    return p


# ------------------------------------------------------------------------------ main


def main(argv: list[str] | None = None) -> int:
    """Run the evaluation; see the module docstring for the exit codes."""
    opts = build_parser().parse_args(argv)
    with quiet_stderr():
        from safe_legged_c3bf.sim.scenario import ScenarioError

    problem = _usage_problem(opts)
    if problem:
        print(f"evaluate: {problem}", file=sys.stderr)
        return EXIT_USAGE
    if opts.combine:
        return combine(opts.combine, opts.out, not opts.no_figures, argv)
    suite = "custom" if opts.scenario else opts.suite
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    out = (opts.out or Path("runs") / f"evaluation-{suite}-{stamp}").resolve()
    out.mkdir(parents=True, exist_ok=True)
    try:
        cases = plan_cases(opts, out)
        specs = plan_runs(cases, opts, out, suite)
    except ScenarioError as err:
        print(f"evaluate: {err}", file=sys.stderr)
        return EXIT_USAGE
    durations = {s.run_id: float(opts.duration or c.duration)
                 for c in cases for s in specs if s.case == c.case}
    _announce(suite, cases, specs, durations, opts, out)
    if opts.compare_body_models is not None and not opts.dry_run and not body_model_supported():
        print("evaluate: --compare-body-models: the installed safety filter has no "
              "'body_model' parameter (safe_legged_c3bf/safety/params.py)", file=sys.stderr)
        return EXIT_USAGE
    if opts.compare_perception and opts.compare_body_models is not None:
        print("evaluate: --compare-perception and --compare-body-models: one comparison at a "
              "time", file=sys.stderr)
        return EXIT_USAGE
    if opts.dry_run:
        for s in specs:
            print(f"  {s.run_id}: {s.scenario} filter {'on' if s.filter_enabled else 'OFF'}"
                  f"{' body_model ' + s.body_model if s.body_model else ''}"
                  f"{' perception ' + s.perception if s.perception else ''}"
                  f"{' seed ' + str(s.seed) if s.seed is not None else ''}")
        return EXIT_OK
    if not specs:
        print("evaluate: nothing to run", file=sys.stderr)
        return EXIT_FAILED
    pool, where = _make_pool(opts, out)
    if pool is None:
        return where  # the exit code; the problem was printed
    state = CampaignState(out, {"in_process": bool(opts.in_process),
                                "full_duration": bool(opts.full_duration)})
    try:
        result = run_campaign(specs, durations, pool, state, restart=opts.restart)
    except CampaignMismatchError as err:
        print(f"evaluate: {err}", file=sys.stderr)
        return EXIT_USAGE
    records = result.records
    notes = [
        f"Suite `{suite}`: {len(cases)} scenario(s), {len(records)} of {len(specs)} run(s) "
        f"finished{_session_note(result)}, {where}"
        f"{' (in-process)' if opts.in_process else ''}; "
        f"{datetime.now().strftime('%Y-%m-%d %H:%M')}.",
        _command_note(argv),
    ]
    paths = _write_results(records, out, title=f"Evaluation: {suite}", notes=notes,
                           figures=not opts.no_figures)
    _print_summary(records, paths)
    return _exit_code(records, specs, result.interrupted)


def _session_note(result: CampaignResult) -> str:
    """'in 12.3 min wall' or '(31 by earlier sessions; this one ran 19 in 12.3 min wall)'."""
    if not result.resumed:
        return f" in {result.wall / 60:.1f} min wall"
    return (f" ({result.resumed} by earlier sessions; this one ran {result.ran} in "
            f"{result.wall / 60:.1f} min wall)")


def _make_pool(opts: argparse.Namespace, out: Path) -> tuple[Any, Any]:
    """(pool, description) for the options, or (None, exit code) after printing why not."""
    if not opts.ray:
        pool = Runner(out, jobs=opts.jobs, in_process=opts.in_process,
                      full_duration=opts.full_duration)
        return pool, f"{opts.jobs} at a time"
    from safe_legged_c3bf.evaluation import ray_pool

    memory = int(opts.ray_memory * 2**30) if opts.ray_memory else None
    try:
        cluster = ray_pool.connect(None if opts.ray == "local" else opts.ray)
        ray_pool.check_capacity(opts.ray_cpus, memory)
    except ray_pool.RayUnavailableError as err:
        print(f"evaluate: {err}", file=sys.stderr)
        return None, EXIT_USAGE
    except ray_pool.RayConnectError as err:
        print(f"evaluate: --ray: {err}", file=sys.stderr)
        return None, EXIT_FAILED
    where = (f"on Ray ({'started here' if opts.ray == 'local' else opts.ray}: {cluster}), "
             f"{opts.ray_cpus:g} CPUs per run")
    print(f"evaluate: {where}", flush=True)
    pool = ray_pool.RayPool(out, cpus=opts.ray_cpus, memory=memory, in_process=opts.in_process,
                            full_duration=opts.full_duration, shared_dir=opts.shared_dir)
    return pool, where


def _usage_problem(opts: argparse.Namespace) -> str | None:
    """What is wrong with options argparse accepts (None if nothing)."""
    if opts.jobs < 1 or (opts.seeds is not None and opts.seeds < 1):
        return "--jobs and --seeds must be >= 1"
    if opts.duration is not None and not opts.duration > 0:
        return "--duration must be positive"
    if not opts.ray_cpus > 0 or (opts.ray_memory is not None and not opts.ray_memory > 0):
        return "--ray-cpus and --ray-memory must be positive"
    if opts.shared_dir is not None and not opts.ray:
        return "--shared-dir needs --ray (the local pool writes into --out)"
    return None


def _announce(suite: str, cases: list[Case], specs: list[RunSpec], durations: dict[str, float],
              opts: argparse.Namespace, out: Path) -> None:
    """Print what will run and a rough wall-time estimate (min)."""
    how = (f"as Ray tasks of {opts.ray_cpus:g} CPUs" if opts.ray else f"{opts.jobs} at a time")
    print(f"evaluate: suite {suite}: {len(cases)} scenario(s), {len(specs)} run(s), "
          f"{how}{', in-process' if opts.in_process else ''}; output {out}", flush=True)
    sim_total = sum(durations.values())
    estimate = "" if opts.ray else (
        f" (at a real-time factor of ~0.35 about {sim_total / 0.35 / opts.jobs / 60:.0f} min)")
    print(f"evaluate: {sim_total:.0f} s of sim time in total{estimate}", flush=True)


def _exit_code(records: list[dict[str, Any]], specs: list[RunSpec], interrupted: bool) -> int:
    """130 if interrupted, EXIT_FAILED if some run could not be executed, else EXIT_OK."""
    if interrupted:
        return 130
    unexecuted = [r for r in records if r["outcome"] == "startup_failed"]
    if unexecuted or len(records) < len(specs):
        print(f"evaluate: {len(unexecuted)} run(s) could not be executed: "
              + ", ".join(r["run_id"] for r in unexecuted), file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _command_note(argv: list[str] | None) -> str:
    """The command line, for the notes of results.md."""
    return ("Command: `python -m safe_legged_c3bf.evaluate "
            + " ".join(argv if argv is not None else sys.argv[1:]) + "`")


def combine(folders: list[Path], out: Path | None, figures: bool,
            argv: list[str] | None) -> int:
    """Merge the result rows of several evaluation folders into one set of tables."""
    from safe_legged_c3bf.evaluation.results import read_csv

    records: list[dict[str, Any]] = []
    for folder in folders:
        path = folder / "results.csv"
        if not path.is_file():
            print(f"evaluate: --combine: no results.csv in {folder}", file=sys.stderr)
            return EXIT_USAGE
        records += read_csv(path)
    ids = [r["run_id"] for r in records]
    if len(set(ids)) != len(ids):
        print("evaluate: --combine: the folders share run ids (the same evaluation twice?)",
              file=sys.stderr)
        return EXIT_USAGE
    out = (out or Path("runs") / f"evaluation-combined-{datetime.now():%Y%m%d-%H%M%S}").resolve()
    out.mkdir(parents=True, exist_ok=True)
    notes = [
        f"Combined from {', '.join(str(f) for f in folders)} ({len(records)} runs); "
        f"{datetime.now().strftime('%Y-%m-%d %H:%M')}.",
        _command_note(argv),
    ]
    paths = _write_results(attach_overhead(records), out, title="Evaluation: combined",
                           notes=notes, figures=figures)
    _print_summary(records, paths)
    return EXIT_OK


def _print_summary(records: list[dict[str, Any]], paths: dict[str, Path]) -> None:
    from safe_legged_c3bf.evaluation.metrics import aggregate, collision_bound

    print("\nevaluate: summary (obstacle runs; rates over valid runs; 95 % intervals in "
          "results.md)")
    rows = aggregate(records, ("robot", "filter"))
    for row in rows:
        def pct(x: float | None) -> str:
            return "  – " if x is None else f"{100 * x:3.0f}%"

        clear = row["clearance_min"]
        over = row["overhead_mean_s"]
        print(f"  {row['robot']:<9} filter {row['filter']:<3}  runs {row['runs']:>3}"
              f"  collision {pct(row['collision_rate'])}  goal {pct(row['goal_rate'])}"
              f"  success {pct(row['success_rate'])}  min clearance "
              f"{'–' if clear is None else f'{clear if abs(clear) >= 5e-4 else 0.0:.3f} m'}"
              f"  overhead {'–' if over is None or not math.isfinite(over) else f'{over:+.1f} s'}"
              f"  run failures {row['run_failures']}")
    for row in rows:
        print(f"  {row['robot']} filter {row['filter']}: {collision_bound(row)}")
    for key in ("markdown", "csv", "summary"):
        print(f"  {key:<9} {paths[key]}")


if __name__ == "__main__":
    raise SystemExit(main())
