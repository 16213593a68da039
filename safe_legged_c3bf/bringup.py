"""Start, watch and keep a run of the whole node graph: ``python -m safe_legged_c3bf.bringup``.

Runs the simulator bridge, obstacle tracker, reference planner, C3BF safety filter and gait
controller on a scenario (default ``quadruped_default``, headless), each node in its own process
(or all on one executor with ``--in-process``), on a private ROS domain restricted to this host
unless ``--domain-id`` is given. While it runs a progress line shows sim time, real-time factor,
distance to the goal and the filter status. At the end it prints a summary and writes a run
folder (``--out``, default ``runs/<scenario>-<timestamp>/``) with ``report.json``, plots, the
node logs and, on request, an MCAP recording (``--record``) and a video (``--video``).

Exit codes: 0 the run completed (also when the robot collided or fell: the report says so);
1 a node died or the simulation stalled; 2 start-up failed (bad arguments, unknown scenario,
missing node module, no simulation time within ``--startup-timeout``); 130 / 143 stopped by
SIGINT (Ctrl-C) / SIGTERM. See doc/bringup.md.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from safe_legged_c3bf.run.outcome import EXIT_OK, EXIT_STARTUP, StartupError
from safe_legged_c3bf.run.plan import make_plan
from safe_legged_c3bf.run.session import OUTCOME_HOLD, Session
from safe_legged_c3bf.sim.scenario_sections import PERCEPTION_SOURCES

DEFAULT_SCENARIO = "quadruped_default"


def build_parser() -> argparse.ArgumentParser:
    """The bringup's command line."""
    p = argparse.ArgumentParser(
        prog="python -m safe_legged_c3bf.bringup",
        description="Run the safe_legged_c3bf node graph on a scenario and report on it.",
        epilog="Exit codes: 0 run completed (even with a collision: see the report), 1 a node "
        "died, 2 start-up failed, 130/143 interrupted by SIGINT/SIGTERM.",
    )
    p.add_argument("--scenario", default=DEFAULT_SCENARIO, metavar="NAME|PATH",
                   help=f"scenario name in config/scenarios or a YAML path "
                   f"(default {DEFAULT_SCENARIO})")
    p.add_argument("--list-scenarios", action="store_true", help="list scenario names and exit")
    p.add_argument("--gui", action="store_true", help="open the PyBullet GUI (needs a display)")
    p.add_argument("--no-filter", action="store_true",
                   help="run the safety filter disabled (pass-through), for comparison")
    p.add_argument("--perception", choices=PERCEPTION_SOURCES,
                   help="where obstacle detections come from: the simulator's oracle (noisy "
                   "true shapes) or the obstacle detector on the simulated LiDAR and 3-D "
                   "sensor (default: the scenario's perception.source, else oracle)")
    p.add_argument("--in-process", action="store_true",
                   help="compose all nodes on one executor in this process")
    p.add_argument("--record", metavar="FILE.mcap", type=Path,
                   help="record every contract topic to an MCAP file (Foxglove, ros2 bag)")
    p.add_argument("--video", metavar="FILE.gif|.mp4", type=Path,
                   help="write the simulator's follow-camera video (headless)")
    p.add_argument("--video-fps", type=float, default=10.0, metavar="FPS",
                   help="video frames per simulated second (default 10)")
    p.add_argument("--lockstep", action=argparse.BooleanOptionalAction, default=True,
                   help="the simulator waits for the gait controller's command of every state "
                   "(default: on, so a slow machine slows the run down instead of starving "
                   "the controller and dropping the robot; --no-lockstep paces physics by "
                   "the wall clock alone)")
    p.add_argument("--real-time-factor", type=float, metavar="X",
                   help="simulator pacing: sim seconds per wall second (0 = as fast as "
                   "possible; default the simulator's, 1)")
    p.add_argument("--duration", type=float, metavar="S",
                   help="override the scenario duration (s, sim time)")
    p.add_argument("--seed", type=int, metavar="N", help="override the scenario seed")
    p.add_argument("--full-duration", dest="stop_on_outcome", action="store_false",
                   help="run to the scenario's duration (default: end the run "
                   f"{OUTCOME_HOLD:g} s (sim) after its outcome is settled: the goal reached, "
                   "the first collision or a fall)")
    p.add_argument("--stop-on-outcome", dest="stop_on_outcome", action="store_true",
                   help="end the run once its outcome is settled (the default; kept for "
                   "scripts that pass it)")
    p.set_defaults(stop_on_outcome=True)
    p.add_argument("--domain-id", type=int, metavar="N",
                   help="use this ROS_DOMAIN_ID as is (default: lease a private one, "
                   "localhost only)")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="run folder (default runs/<scenario>-<timestamp>/)")
    p.add_argument("--remap", action="append", default=[], metavar="FROM:=TO",
                   help="topic remapping applied to every node (repeatable)")
    p.add_argument("--node", action="append", default=[], metavar="NAME=MODULE",
                   help="run MODULE instead of the standard module for node NAME (repeatable)")
    p.add_argument("--executor", choices=("events", "single", "multi"), default=None,
                   help="rclpy executor of every node process, or of the one process with "
                        "--in-process (default events; multi: --in-process only)")
    p.add_argument("--startup-timeout", type=float, default=60.0, metavar="S",
                   help="wall seconds to wait for simulation time to start (default 60)")
    p.add_argument("--stall-timeout", type=float, default=30.0, metavar="S",
                   help="wall seconds without simulation progress before giving up "
                   "(default 30)")
    p.add_argument("--progress-period", type=float, metavar="S",
                   help="seconds between progress lines (default 0.25 on a terminal, where "
                   "the line is rewritten in place, else 5)")
    g = p.add_argument_group(
        "deployment on a real robot (doc/deploy.md)",
        "--deploy runs the safety pipeline alone (obstacle detector, tracker, filter) on the "
        "robot's topics: /scan and/or /points, /odom and /cmd_vel in, /cmd_vel_safe out; no "
        "simulator, no scenario, the environment's ROS domain, the system clock.")
    g.add_argument("--deploy", action="store_true", help="run the safety pipeline alone")
    g.add_argument("--robot", default="quadruped", metavar="KIND",
                   help="robot profile and sensor mounts: quadruped (default) or biped")
    g.add_argument("--with-planner", action="store_true",
                   help="also run the reference planner (goals on /goal_pose)")
    g.add_argument("--use-sim-time", action="store_true",
                   help="run the pipeline on /clock (replaying a recording)")
    g.add_argument("--params-file", action="append", default=[], type=Path, metavar="FILE",
                   help="ROS 2 parameter file applied last to the pipeline's nodes "
                   "(repeatable)")
    p.add_argument("--verbose", "-v", action="store_true",
                   help="also print the nodes' log lines (they always go to <out>/logs/)")
    return p


# ------------------------------------------------------------------------------ entry point


def _isolate(opts: argparse.Namespace):  # noqa: ANN202 - DomainLease | None
    """Choose the ROS domain for this process and every child (before rclpy starts)."""
    if opts.domain_id is not None:
        if not 0 <= opts.domain_id <= 232:
            raise StartupError("--domain-id must be in 0..232")
        os.environ["ROS_DOMAIN_ID"] = str(opts.domain_id)
        if os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST":
            from safe_legged_c3bf.run.ros_domain import restrict_to_localhost

            restrict_to_localhost(os.environ)  # the same range, without shared memory
        return None
    from safe_legged_c3bf.run.ros_domain import isolate_environment

    try:
        _, lease = isolate_environment()
    except RuntimeError as err:
        raise StartupError(str(err)) from None
    return lease


def main(args: list[str] | None = None) -> int:
    """Command-line entry point."""
    opts = build_parser().parse_args(sys.argv[1:] if args is None else args)
    if opts.list_scenarios:
        from safe_legged_c3bf.sim.scenario import available_scenarios

        print("\n".join(available_scenarios()))
        return EXIT_OK
    if opts.deploy:
        return _deploy(opts)
    lease = None
    try:
        plan = make_plan(opts)
        lease = _isolate(opts)
    except StartupError as err:
        print(f"bringup: start-up failed: {err}", file=sys.stderr)
        return EXIT_STARTUP
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    from safe_legged_c3bf.run.ros_domain import is_localhost_only

    local = is_localhost_only(os.environ)
    print(
        f"bringup: scenario {plan.scenario.name} ({plan.context.robot}, "
        f"{plan.scenario.duration:g} s sim), "
        f"filter {'on' if plan.context.filter_enabled else 'OFF'}, "
        f"perception {plan.context.perception}, "
        f"{'in-process' if opts.in_process else 'one process per node'}\n"
        f"bringup: ROS domain {domain}{' (localhost only)' if local else ''}; watch with "
        f"`python -m safe_legged_c3bf.echo /cmd_vel_safe --domain-id {domain}`\n"
        f"bringup: run folder {plan.run_dir}",
        flush=True,
    )
    try:
        return Session(opts, plan).run()
    except StartupError as err:
        print(f"bringup: start-up failed: {err}", file=sys.stderr)
        return EXIT_STARTUP
    finally:
        if lease is not None:
            lease.release()


def _deploy(opts: argparse.Namespace) -> int:
    """``--deploy``: the safety pipeline on a real robot's topics until Ctrl-C."""
    from datetime import datetime

    from safe_legged_c3bf.run.deploy import run_deploy

    run_dir = (opts.out or Path("runs") / f"deploy-{datetime.now():%Y%m%d-%H%M%S}").resolve()
    try:
        if opts.domain_id is not None:
            _isolate(opts)
        domain = os.environ.get("ROS_DOMAIN_ID", "0")
        print(f"bringup: deploy on ROS domain {domain}, run folder {run_dir}", flush=True)
        return run_deploy(opts, run_dir)
    except StartupError as err:
        print(f"bringup: start-up failed: {err}", file=sys.stderr)
        return EXIT_STARTUP


if __name__ == "__main__":
    raise SystemExit(main())
