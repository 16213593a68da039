"""Command line: ``python -m safe_legged_c3bf.replay RECORDING.mcap [--check]``."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from safe_legged_c3bf.replay.kpis import KpiLimits
from safe_legged_c3bf.replay.recording import RecordingError


def build_parser() -> argparse.ArgumentParser:
    """The replay's command line."""
    p = argparse.ArgumentParser(
        prog="python -m safe_legged_c3bf.replay",
        description="Play a recording's /scan, /points, /odom and /cmd_vel into the safety "
        "pipeline (detector, tracker, filter; no simulator) and score the filtered command "
        "against the recording's ground truth.",
        epilog="Exit codes: 0 done (with --check: every KPI within its limit), 1 a KPI failed "
        "(--check), 2 bad arguments or an unreadable recording.",
    )
    p.add_argument("recording", type=Path, help="MCAP file written by bringup --record")
    p.add_argument("--robot", default="quadruped", help="robot profile: quadruped or biped")
    p.add_argument("--rate", type=float, default=1.0,
                   help="sim seconds played per wall second (default 1)")
    p.add_argument("--params-file", action="append", default=[], type=Path, metavar="FILE",
                   help="ROS 2 parameter file for the pipeline's nodes (repeatable)")
    p.add_argument("--json", type=Path, metavar="FILE", help="write the scores as JSON")
    p.add_argument("--check", action="store_true", help="exit 1 when a KPI fails its limit")
    lim = KpiLimits()
    p.add_argument("--max-reaction", type=float, default=lim.reaction, metavar="S")
    p.add_argument("--max-cone-exit", type=float, default=lim.cone_exit, metavar="S")
    p.add_argument("--max-false", type=float, default=lim.false_intervention_share,
                   metavar="SHARE")
    return p


def main(args: list[str] | None = None) -> int:
    """Entry point."""
    opts = build_parser().parse_args(sys.argv[1:] if args is None else args)
    from safe_legged_c3bf.replay.run import replay
    from safe_legged_c3bf.run.outcome import StartupError
    from safe_legged_c3bf.run.ros_domain import isolate_environment

    limits = KpiLimits(reaction=opts.max_reaction, cone_exit=opts.max_cone_exit,
                       false_intervention_share=opts.max_false)
    try:
        _, lease = isolate_environment()
    except RuntimeError as err:
        print(f"replay: {err}", file=sys.stderr)
        return 2
    try:
        result = replay(opts.recording, opts.robot, opts.rate, opts.params_file, limits)
    except (RecordingError, StartupError, ValueError) as err:
        print(f"replay: {err}", file=sys.stderr)
        return 2
    finally:
        lease.release()
    rep = result.report
    figures = rep.as_dict()
    print(_summary(result, figures))
    if opts.json is not None:
        opts.json.write_text(json.dumps(
            {"recording": str(opts.recording), "robot": opts.robot, "pad": result.pad,
             "limits": asdict(limits), "counts": result.recording.counts,
             "wall_time": result.wall_time, **figures}, indent=2) + "\n")
    return 1 if opts.check and not rep.passed else 0


def _summary(result, f: dict) -> str:  # noqa: ANN001 - ReplayResult
    def ms(x: float | None) -> str:
        return "-" if x is None else f"{x * 1e3:.0f} ms"

    rec = result.recording
    lines = [
        f"replay {rec.path.name}: {rec.duration:.1f} s sim in {result.wall_time:.1f} s wall, "
        f"{f['cycles']} filter cycles, played " + ", ".join(
            f"{k} {v}" for k, v in rec.counts.items() if v),
        f"  cone entries      {f['entries']} (missed {f['missed']})",
        f"  reaction          median {ms(f['reaction_median'])}, max {ms(f['reaction_max'])}",
        f"  cone exit         median {ms(f['cone_exit_median'])}, max {ms(f['cone_exit_max'])}",
        f"  false interventions {f['false_intervention_share']:.1%} of "
        f"{f['free_cycles']} free-path cycles",
        "  KPIs              " + ("pass" if f["passed"] else "FAIL: " + "; ".join(f["failures"])),
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
