"""The end of a run: say how it ended, write the run folder, print the summary."""

from __future__ import annotations

import json
import os
import sys
import time
from typing import TYPE_CHECKING, Any

from safe_legged_c3bf.run.console import say
from safe_legged_c3bf.run.report import format_summary, write_run_folder

if TYPE_CHECKING:
    from safe_legged_c3bf.run.session import Session


def finish(session: Session) -> int:
    """Report the stopped run ``session``: stderr message, run folder, summary; exit code."""
    session.progress.clear()
    plan, outcome = session.plan, session.outcome
    ctx = plan.context
    ctx.wall_time = time.monotonic() - session.wall_start
    ctx.outcome, ctx.reason = outcome.kind, outcome.reason
    ctx.cpu_seconds = session.launcher.cpu_seconds()
    _say_failure(session)
    extra = _run_facts(session)
    simulator = None
    sim_summary = plan.run_dir / "simulator_summary.json"
    if sim_summary.exists():
        try:
            simulator = json.loads(sim_summary.read_text())
        except (OSError, ValueError):
            simulator = None
    opts = session.opts
    if opts.record is not None:
        extra["recording"] = str(opts.record.resolve())
    if opts.video is not None:
        video = opts.video.resolve()
        extra["video"] = str(video) if video.is_file() else None
        if not video.is_file():
            say(None, f"--video: the simulator wrote no video to {video} (its node must "
                "support the video_path / video_fps parameters)")
    monitor = session.monitor
    report = write_run_folder(plan.run_dir, monitor.data, ctx, monitor.sim_time, extra, simulator)
    print(format_summary(report["summary"], plan.run_dir), flush=True)
    return outcome.exit_code


def _say_failure(session: Session) -> None:
    """On stderr: which node died and its last lines, or why the run did not complete."""
    outcome = session.outcome
    if outcome.kind == "node_died":
        label = session.launcher.failure_label
        say(None, outcome.reason + (f"; {label}:" if outcome.details else " (no stderr output)"))
        for line in outcome.details:
            print(f"    {line}", file=sys.stderr)
        log = session.plan.run_dir / "logs" / f"{outcome.failed_node}.log"
        if log.exists():
            print(f"  full log: {log}", file=sys.stderr)
        print("bringup: stopped the other nodes", file=sys.stderr, flush=True)
    elif outcome.kind != "completed":
        say(None, f"{outcome.kind.replace('_', ' ')}: {outcome.reason}")


def _run_facts(session: Session) -> dict[str, Any]:
    """What report.json adds to the summary: exit code, command, domain, files, nodes."""
    plan, outcome = session.plan, session.outcome
    extra: dict[str, Any] = {
        "exit_code": outcome.exit_code,
        "command": sys.argv,
        "ros_domain_id": os.environ.get("ROS_DOMAIN_ID"),
        "scenario_file": str(plan.scenario_file),
        # no node process started (in-process, or stopped before any): the planned modules
        "nodes": session.launcher.node_table() or {
            s.name: {"module": s.module, "in_process": True} for s in plan.specs
        },
    }
    if outcome.details:
        extra["failure_details"] = outcome.details
    return extra
