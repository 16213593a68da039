"""Run many bringups in parallel and turn their ``report.json`` into classified result rows.

Each :class:`RunSpec` becomes one ``python -m safe_legged_c3bf.bringup`` subprocess with its own
run folder (``<out>/runs/<run_id>/``, its stdout/stderr in ``bringup.log`` there). The
bringup leases its own private ROS domain (``safe_legged_c3bf.run.ros_domain``), so parallel runs
never hear each other. At most ``jobs`` run at a time; a progress line is printed when a run
starts and when it ends. A run that exceeds its wall-clock limit gets SIGINT (the bringup
then stops its nodes and writes a partial report), SIGKILL to its process group after a grace
period.

:func:`record_from_report` flattens a report into one row (a plain dict: what
:mod:`~safe_legged_c3bf.evaluation.results` aggregates and writes to CSV) and
:func:`classify` names the outcome:

=====================  ========================================================================
outcome                meaning
=====================  ========================================================================
``ok``                 completed, goal reached, no collision, not fallen
``collided``           the ground truth saw a robot-obstacle contact
``fell``               the base went too low or tilted too far (no collision)
``incomplete_report``  the report lacks ``collision``, ``fallen`` or ``goal_reached`` (or one is
                       not true/false): the run proves nothing, so it is never ``ok``
``goal_not_reached``   the scenario ended (sim time) before the robot reached its goal
``stopped_impassable`` the goal was not reached, but an impassable obstacle blocks the path and
                       the robot stopped before it, untouched, and held the stop to the end
                       (:mod:`.expectations`): the expected outcome, a success
``node_died``          a node died or the simulation stalled (bringup exit 1, report outcome
                       ``node_died`` or ``stalled``), or the bringup failed with another code
``startup_failed``     the run could not start (bringup exit 2, or no report was written)
``wall_timeout``       the runner stopped the run after its wall-clock limit
``interrupted``        the run was stopped by a signal (Ctrl-C of the evaluation: bringup exit
                       129/130/143, or killed)
=====================  ========================================================================

The outcome is the first of :data:`OUTCOMES` that applies. ``failures`` lists every flag that
applies (e.g. ``collided+goal_not_reached``); the extra flag ``infeasible`` marks runs in which
the filter's QP was infeasible for some time (status ``RELAXED``: the barrier constraints were
relaxed), with its share of time in ``relaxed_share``.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from safe_legged_c3bf.run.process_group import stop_groups

#: Outcomes in priority order (the first that applies names the run).
OUTCOMES = (
    "startup_failed", "node_died", "wall_timeout", "interrupted", "collided", "fell",
    "incomplete_report", "goal_not_reached", "stopped_impassable", "ok",
)
#: Outcomes for which the run produced no trustworthy result.
RUN_FAILURES = frozenset(
    {"startup_failed", "node_died", "wall_timeout", "interrupted", "incomplete_report"}
)
#: Report fields without which a run says nothing about safety or success (true/false each).
REQUIRED_FIELDS = ("collision", "fallen", "goal_reached")
#: Bringup exit codes: completed, a node died, start-up failed, stopped by SIGHUP/INT/TERM.
EXIT_OK, EXIT_FAILED, EXIT_STARTUP, EXIT_SIGNALS = 0, 1, 2, (129, 130, 143)
#: Wall-clock allowance of a run: STARTUP_ALLOWANCE + duration / MIN_REAL_TIME_FACTOR.
STARTUP_ALLOWANCE = 120.0
MIN_REAL_TIME_FACTOR = 0.08
#: Seconds between SIGINT and SIGKILL when stopping a run.
STOP_GRACE = 15.0


@dataclass(frozen=True)
class RunSpec:
    """One bringup run of an evaluation.

    Attributes:
        run_id: unique name, also the run folder name.
        case: what the run belongs to: the filter-on, filter-off and obstacle-free runs of one
            scenario (and seed) share it.
        scenario: scenario name or YAML path given to ``--scenario``.
        robot: 'quadruped' or 'biped'.
        kind: scenario kind for the tables ('static', 'moving', 'horizontal', 'random', ...).
        filter_enabled: False runs the bringup with ``--no-filter``.
        variant: 'obstacles' (the scenario as is) or 'free' (obstacles removed: the reference
            for the time-to-goal overhead).
        suite: name of the suite that asked for it.
        seed: ``--seed`` override (None: the scenario's own).
        duration: ``--duration`` override in sim seconds (None: the scenario's).
        extra_args: further bringup arguments.
        body_model: the filter's ``body_model`` the scenario file sets ('' = its default).
        perception: ``--perception`` of the bringup, 'oracle' or 'sensors' ('' = the
            scenario's own).

    """

    run_id: str
    case: str
    scenario: str
    robot: str
    kind: str
    filter_enabled: bool = True
    variant: str = "obstacles"
    suite: str = ""
    seed: int | None = None
    duration: float | None = None
    extra_args: tuple[str, ...] = field(default_factory=tuple)
    body_model: str = ""
    perception: str = ""


def bringup_command(
    spec: RunSpec, run_dir: Path, in_process: bool = False, python: str | None = None,
    full_duration: bool = False,
) -> list[str]:
    """The command line of the bringup subprocess of ``spec``.

    Runs end once their outcome is settled (goal reached, collision or fall; the bringup's
    default, passed as ``--stop-on-outcome``) unless ``full_duration`` (``--full-duration``).
    """
    cmd = [python or sys.executable, "-m", "safe_legged_c3bf.bringup",
           "--scenario", str(spec.scenario), "--out", str(run_dir), "--progress-period", "5"]
    cmd.append("--full-duration" if full_duration else "--stop-on-outcome")
    if not spec.filter_enabled:
        cmd.append("--no-filter")
    if in_process:
        cmd.append("--in-process")
    if spec.seed is not None:
        cmd += ["--seed", str(int(spec.seed))]
    if spec.duration is not None:
        cmd += ["--duration", f"{float(spec.duration):g}"]
    if spec.perception:
        cmd += ["--perception", spec.perception]
    cmd += list(spec.extra_args)
    return cmd


# ------------------------------------------------------------------------------ records


def _get(d: Any, *keys: str, default: Any = None) -> Any:
    for key in keys:
        if not isinstance(d, dict) or key not in d:
            return default
        d = d[key]
    return default if d is None else d


def _num(x: Any) -> float | None:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def record_from_report(
    spec: RunSpec | dict[str, Any],
    report: dict[str, Any] | None,
    exit_code: int | None = 0,
    wall_time: float | None = None,
    timed_out: bool = False,
    run_dir: str | Path | None = None,
) -> dict[str, Any]:
    """One flat result row from a run's spec, its ``report.json`` (or None) and its exit.

    Works on synthetic report dicts: missing fields become None.
    """
    base = asdict(spec) if isinstance(spec, RunSpec) else dict(spec)
    base.pop("extra_args", None)
    summary = _get(report, "summary", default={})
    filt = summary.get("filter") or {}
    shares = filt.get("status_share") or {}
    solve = filt.get("solve_time_ms") or {}
    goal = summary.get("goal") or {}
    rec: dict[str, Any] = {
        "run_id": base.get("run_id", ""),
        "case": base.get("case", ""),
        "suite": base.get("suite", ""),
        "scenario": summary.get("scenario") or Path(str(base.get("scenario", ""))).stem,
        "robot": base.get("robot") or summary.get("robot") or "",
        "kind": base.get("kind", ""),
        "variant": base.get("variant", "obstacles"),
        "filter": "on" if base.get("filter_enabled", True) else "off",
        "body_model": base.get("body_model") or "",
        "perception": summary.get("perception") or base.get("perception") or "oracle",
        "seed": base.get("seed"),
        "exit_code": exit_code,
        "timed_out": bool(timed_out),
        "has_report": report is not None,
        "run_outcome": summary.get("outcome"),
        "collision": summary.get("collision"),
        "collision_count": summary.get("collision_count"),
        "obstacles_touched": "+".join(summary.get("obstacles_touched") or []),
        "fallen": summary.get("fallen"),
        "goal_reached": goal.get("reached"),
        "goal_time": _num(goal.get("time_reached")),
        "final_goal_distance": _num(goal.get("final_distance")),
        "min_clearance": _num(summary.get("min_clearance")),
        "min_clearance_obstacle": summary.get("min_clearance_obstacle"),
        "path_length": _num(summary.get("path_length")),
        "intervention_share": _num(filt.get("intervention_share")),
        "relaxed_share": _num(shares.get("RELAXED", 0.0 if shares else None)),
        "brake_share": _num(shares.get("EMERGENCY_BRAKE", 0.0 if shares else None)),
        "filter_cycles": filt.get("cycles"),
        "solve_median_ms": _num(solve.get("median")),
        "solve_p99_ms": _num(solve.get("p99")),
        "solve_max_ms": _num(solve.get("max")),
        "sim_time": _num(summary.get("sim_time")),
        "duration": _num(summary.get("duration")),
        "real_time_factor": _num(summary.get("real_time_factor")),
        "wall_time": _num(wall_time if wall_time is not None else summary.get("wall_time")),
        "run_dir": str(run_dir) if run_dir is not None else "",
    }
    if rec["filter"] == "off":  # pass-through: no solves, no interventions to speak of
        for key in ("solve_median_ms", "solve_p99_ms", "solve_max_ms", "intervention_share",
                    "relaxed_share", "brake_share"):
            rec[key] = None
    outcome, failures = classify(rec)
    rec["outcome"] = outcome
    rec["failures"] = "+".join(failures)
    rec["reason"] = _get(report, "summary", "reason", default="") if report else (
        "no report.json was written"
    )
    return rec


def classify(rec: dict[str, Any]) -> tuple[str, list[str]]:
    """(outcome, failure flags) of a result row; see the module docstring.

    Fails closed: a run is ``ok`` only with a report whose ``collision`` and ``fallen`` are
    false and ``goal_reached`` is true, from a bringup that exited 0.
    """
    flags: list[str] = []
    code = rec.get("exit_code")
    run = rec.get("run_outcome")
    has_report = rec.get("has_report", True)
    if rec.get("timed_out"):
        flags.append("wall_timeout")
    elif not has_report or code == EXIT_STARTUP or run == "startup_failed":
        flags.append("startup_failed")
    elif code == EXIT_FAILED or run in ("node_died", "stalled"):
        flags.append("node_died")
    elif code in EXIT_SIGNALS or (code is not None and code < 0) or run == "interrupted":
        flags.append("interrupted")
    elif code is not None and code != EXIT_OK:  # no bringup code: failed all the same
        flags.append("node_died")
    if rec.get("collision"):
        flags.append("collided")
    if rec.get("fallen"):
        flags.append("fell")
    if has_report and not all(isinstance(rec.get(f), bool) for f in REQUIRED_FIELDS):
        flags.append("incomplete_report")
    if has_report and rec.get("goal_reached") is False:
        flags.append("stopped_impassable" if rec.get("stopped_before_impassable")
                     else "goal_not_reached")
    if (rec.get("relaxed_share") or 0.0) > 0.0:
        flags.append("infeasible")
    return next((o for o in OUTCOMES if o in flags), "ok"), flags


# ------------------------------------------------------------------------------ running


@dataclass
class _Active:
    spec: RunSpec
    proc: subprocess.Popen
    started: float


class Runner:
    """Runs :class:`RunSpec` s as bringup subprocesses, ``jobs`` at a time.

    Args:
        out_dir: evaluation folder; run folders go to ``out_dir/runs/<run_id>``.
        jobs: how many bringups at once (each is itself 5-6 processes).
        in_process: pass ``--in-process`` to every bringup.
        full_duration: run every scenario to its end instead of stopping once the outcome
            is settled (goal reached, collision or fall).
        python: interpreter (default: this one).
        progress: called with each progress line (default: print to stdout).
        wall_limit: wall seconds allowed per run given its sim duration (default:
            ``STARTUP_ALLOWANCE + duration / MIN_REAL_TIME_FACTOR``).
        on_start: called with the spec and the bringup's Popen once it started (e.g. to
            watch its process group).

    """

    def __init__(
        self,
        out_dir: str | Path,
        jobs: int = 2,
        in_process: bool = False,
        full_duration: bool = False,
        python: str | None = None,
        progress: Callable[[str], None] | None = None,
        wall_limit: Callable[[float], float] | None = None,
        on_start: Callable[[RunSpec, subprocess.Popen], None] | None = None,
    ) -> None:
        """Prepare a runner writing under ``out_dir``."""
        self.out_dir = Path(out_dir)
        self.jobs = max(1, int(jobs))
        self.in_process = in_process
        self.full_duration = full_duration
        self.python = python or sys.executable
        self._print = progress or (lambda line: print(line, flush=True))
        self._wall_limit = wall_limit or (
            lambda duration: STARTUP_ALLOWANCE + duration / MIN_REAL_TIME_FACTOR
        )
        self._on_start = on_start
        self._lock = threading.Lock()
        self._active: dict[str, _Active] = {}
        self._stopping = False
        self._done = 0
        self._total = 0
        self._t0 = time.monotonic()
        self._on_result: Callable[[dict[str, Any]], None] | None = None

    # ------------------------------------------------------------------ public

    def run(
        self,
        specs: Sequence[RunSpec],
        durations: dict[str, float] | None = None,
        on_result: Callable[[dict[str, Any]], None] | None = None,
    ) -> list[dict[str, Any]]:
        """Run every spec; return their result rows in the order of ``specs``.

        ``durations`` maps run ids to sim durations (for the wall-clock limit; default 30 s).
        ``on_result`` is called with each row as soon as its run ends (from a worker thread,
        one call at a time). A KeyboardInterrupt stops the running bringups (SIGINT) and
        re-raises after they finished writing their reports.
        """
        self._on_result = on_result
        ids = [s.run_id for s in specs]
        if len(set(ids)) != len(ids):
            raise ValueError("run ids must be unique")
        self._total, self._done, self._t0 = len(specs), 0, time.monotonic()
        durations = durations or {}
        results: dict[str, dict[str, Any]] = {}
        pool = ThreadPoolExecutor(max_workers=self.jobs, thread_name_prefix="evaluate")
        try:
            futures = {
                s.run_id: pool.submit(self._run_one, s, durations.get(s.run_id, 30.0))
                for s in specs
            }
            for run_id, fut in futures.items():
                while True:  # wait in slices so Ctrl-C gets through
                    try:
                        results[run_id] = fut.result(timeout=0.5)
                        break
                    except TimeoutError:
                        continue
        except KeyboardInterrupt:
            self.stop_all()
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        pool.shutdown(wait=True)
        return [results[i] for i in ids]

    def stop_all(self) -> None:
        """Stop every running bringup (SIGINT, SIGKILL to the group after the grace period)."""
        with self._lock:
            self._stopping = True
            active = list(self._active.values())
        stop_groups([a.proc for a in active], [(time.monotonic() + STOP_GRACE, signal.SIGKILL)])

    # ------------------------------------------------------------------ internals

    def _say(self, text: str) -> None:
        with self._lock:
            elapsed = time.monotonic() - self._t0
            self._print(f"[{self._done:>3}/{self._total}] {elapsed:6.0f} s  {text}")

    def _run_one(self, spec: RunSpec, duration: float) -> dict[str, Any]:
        run_dir = (self.out_dir / "runs" / spec.run_id).resolve()
        if run_dir.exists():
            for name in ("report.json", "simulator_summary.json"):
                (run_dir / name).unlink(missing_ok=True)
        run_dir.mkdir(parents=True, exist_ok=True)
        with self._lock:
            if self._stopping:
                return record_from_report(spec, None, None, 0.0, False, run_dir) | {
                    "outcome": "interrupted", "failures": "interrupted",
                    "reason": "evaluation interrupted before the run started"}
        cmd = bringup_command(spec, run_dir, self.in_process, self.python, self.full_duration)
        label = run_label(spec)
        self._say(f"start {label}")
        limit = self._wall_limit(spec.duration or duration)
        started = time.monotonic()
        timed_out = False
        with open(run_dir / "bringup.log", "wb") as log:
            log.write(("$ " + " ".join(cmd) + "\n").encode())
            log.flush()
            try:
                proc = subprocess.Popen(
                    cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                    start_new_session=True, env=_child_env(),
                )
            except OSError as err:
                rec = record_from_report(spec, None, None, 0.0, False, run_dir)
                rec["reason"] = f"could not start the bringup: {err}"
                with self._lock:
                    self._done += 1
                self._say(f"done  {label}: startup_failed ({err})")
                return rec
            with self._lock:
                self._active[spec.run_id] = _Active(spec, proc, started)
            try:
                if self._on_start is not None:
                    try:
                        self._on_start(spec, proc)
                    except Exception as err:  # noqa: BLE001 - must not orphan the bringup
                        self._say(f"note  {label}: on_start failed: {err!r}")
                try:
                    code = proc.wait(timeout=limit)
                except subprocess.TimeoutExpired:
                    timed_out = True
                    stop_groups([proc], [(time.monotonic() + STOP_GRACE, signal.SIGKILL)])
                    code = proc.wait()
            finally:
                with self._lock:
                    self._active.pop(spec.run_id, None)
        wall = time.monotonic() - started
        report = _read_report(run_dir / "report.json")
        rec = record_from_report(spec, report, code, wall, timed_out, run_dir)
        if report is not None:
            from safe_legged_c3bf.evaluation.expectations import annotate

            annotate(rec, spec.scenario, run_dir)
        if timed_out:
            rec["reason"] = f"stopped after the wall-clock limit of {limit:.0f} s"
        elif report is None:
            rec["reason"] = f"bringup exited with {code} without a report: " + _tail(
                run_dir / "bringup.log")
        with self._lock:
            self._done += 1
        self._say(f"done  {label} in {wall:.0f} s: {describe(rec)}")
        if self._on_result is not None:
            with self._lock:
                self._on_result(rec)
        return rec


def run_label(spec: RunSpec) -> str:
    """The run in words for the progress output: "<scenario> seed 3 (filter on)"."""
    name = Path(spec.scenario).stem if spec.scenario.endswith((".yaml", ".yml")) else spec.scenario
    seed = "" if spec.seed is None else f" seed {spec.seed}"
    return f"{name}{seed} ({'filter on' if spec.filter_enabled else 'filter OFF'}" + (
        ", no obstacles)" if spec.variant == "free" else ")")


def describe(rec: dict[str, Any]) -> str:
    """One-line description of a result row for the progress output."""
    parts = [rec["outcome"]]
    if rec.get("goal_time") is not None:
        parts.append(f"goal at {rec['goal_time']:.1f} s")
    if rec.get("min_clearance") is not None:
        clearance = rec["min_clearance"] if abs(rec["min_clearance"]) >= 5e-4 else 0.0
        parts.append(f"min clearance {clearance:.3f} m")
    if rec.get("intervention_share") is not None and rec.get("filter") == "on":
        parts.append(f"intervened {100 * rec['intervention_share']:.0f} %")
    if rec.get("real_time_factor") is not None:
        parts.append(f"RTF {rec['real_time_factor']:.2f}")
    extra = [f for f in (rec.get("failures") or "").split("+") if f and f != rec["outcome"]]
    if extra:
        parts.append("also " + ", ".join(extra))
    return "; ".join(parts)


def _child_env() -> dict[str, str]:
    """Environment of a bringup: this one, unbuffered; the bringup leases its own domain."""
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def _read_report(path: Path) -> dict[str, Any] | None:
    try:
        with open(path, encoding="utf-8") as f:
            report = json.load(f)
    except (OSError, ValueError):
        return None
    return report if isinstance(report, dict) else None


def _tail(path: Path, lines: int = 3) -> str:
    try:
        text = path.read_text(encoding="utf-8", errors="replace").strip().splitlines()
    except OSError:
        return ""
    return " | ".join(line.strip() for line in text[-lines:])
