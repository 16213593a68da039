"""Run a bringup with one injected fault and judge the graph's response from ground truth.

:func:`run_fault` starts ``python -m safe_legged_c3bf.bringup`` on a private ROS domain,
joins that domain with a :class:`~safe_legged_c3bf.evaluation.fault_injector.FaultInjector`,
injects the fault once sim time reaches ``fault_time`` (a message fault: a second publisher
from then on; a process fault: SIGKILL or SIGSTOP to that node's process), waits for the
bringup to end and returns one :class:`FaultResult` row: the run's outcome and reason,
collision and goal (ground truth), time to stop, messages rejected, processes left behind,
and whether the fault's expectation (``faults.Fault.expect``) held.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from safe_legged_c3bf.evaluation.faults import FAULTS, Fault
from safe_legged_c3bf.run.ros_domain import lease_domain, restrict_to_localhost

#: Sim seconds a run goes on after a fault that should stop the robot.
STOP_WATCH = 6.0
WALL_LIMIT = 600.0


@dataclass
class FaultResult:
    """One fault's row (see the module docstring); times in sim s, clearance in m."""

    fault: str
    expect: str
    outcome: str
    reason: str
    collision: bool | None
    goal_reached: bool | None
    min_clearance: float | None
    time_to_stop: float | None
    rejected: int
    sent: int
    orphans: list[int]
    passed: bool
    run_dir: str

    def as_dict(self) -> dict:
        """The row as a plain dict (JSON)."""
        return asdict(self)


def _domain_processes(domain_id: int) -> list[int]:
    """Pids of this machine's processes (but this one) running on ROS domain ``domain_id``."""
    key = f"ROS_DOMAIN_ID={domain_id}".encode()
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            environ = (entry / "environ").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().rpartition(")")[2].split()[0]
        except OSError:
            continue
        if key in environ and state != "Z":
            out.append(int(entry.name))
    return out


def _node_pid(domain_id: int, node: str) -> int | None:
    """Pid of graph node ``node`` (its module on the command line) on ``domain_id``."""
    for pid in _domain_processes(domain_id):
        try:
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace")
        except OSError:
            continue
        if "safe_legged_c3bf.run.child" in cmdline and f".{node}_node" in cmdline:
            return pid
    return None


def _judge(fault: Fault, summary: dict, time_to_stop: float | None, orphans: list[int]) -> bool:
    """True when the graph did what ``fault.expect`` says (see ``faults``)."""
    if summary.get("collision") is not False or orphans:
        return False
    if fault.expect == "continue":
        return bool(summary.get("goal", {}).get("reached"))
    if fault.expect == "safe":
        return True
    if fault.expect == "stop":
        return time_to_stop is not None
    return summary.get("outcome") == "node_died" and fault.node in summary.get("reason", "")


def run_fault(
    fault: Fault | str,
    out_dir: str | Path,
    scenario: str = "quadruped_default",
    fault_time: float = 8.0,
    python: str = sys.executable,
) -> FaultResult:
    """Run ``scenario`` with ``fault`` injected at sim time ``fault_time``; see the module."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from safe_legged_c3bf.evaluation.fault_injector import FaultInjector

    fault = FAULTS[fault] if isinstance(fault, str) else fault
    faults = [fault] + ([FAULTS[fault.also]] if fault.also else [])
    run_dir = Path(out_dir) / fault.name
    run_dir.mkdir(parents=True, exist_ok=True)
    lease = lease_domain()
    env = dict(os.environ, ROS_DOMAIN_ID=str(lease.domain_id), PYTHONUNBUFFERED="1")
    restrict_to_localhost(env)
    cmd = [python, "-m", "safe_legged_c3bf.bringup", "--scenario", scenario, "--domain-id",
           str(lease.domain_id), "--out", str(run_dir / "run"), "--stop-on-outcome"]
    if fault.expect == "stop":
        cmd += ["--duration", f"{fault_time + STOP_WATCH:g}"]
    if fault.perception != "oracle":
        cmd += ["--perception", fault.perception]
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=lease.domain_id)
    with open(run_dir / "bringup.log", "w", encoding="utf-8") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env,
                                start_new_session=True)
        node = FaultInjector(faults, context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        try:
            _drive(proc, node, executor, faults, fault_time, lease.domain_id)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            executor.remove_node(node)
            node.destroy_node()
            rclpy.try_shutdown(context=context)
    time.sleep(1.0)  # let the bringup's children finish exiting before counting orphans
    orphans = _domain_processes(lease.domain_id)
    for pid in orphans:
        os.kill(pid, signal.SIGKILL)
    lease.release()
    return _result(fault, run_dir, node, orphans)


def _drive(proc, node, executor, faults, fault_time, domain_id) -> None:  # noqa: ANN001
    """Spin until the bringup exits, injecting the faults at ``fault_time``."""
    deadline = time.monotonic() + WALL_LIMIT
    injected = False
    while proc.poll() is None and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
        if injected or node.sim_time is None or node.sim_time < fault_time:
            continue
        injected = True
        node.start()
        for fault in faults:
            if fault.is_process:
                pid = _node_pid(domain_id, fault.node)
                if pid is not None:
                    os.kill(pid, getattr(signal, fault.signal))


def _result(fault: Fault, run_dir: Path, node, orphans: list[int]) -> FaultResult:  # noqa: ANN001
    report_path = run_dir / "run" / "report.json"
    summary = {}
    if report_path.exists():
        summary = json.loads(report_path.read_text()).get("summary", {})
    collision = summary.get("collision")
    if node.collided:
        collision = True
    summary = {**summary, "collision": collision}
    # A run that goes on stands still at its goal: only a fault that stops it has a time.
    time_to_stop = None if fault.expect in ("continue", "safe") else node.time_to_stop()
    return FaultResult(
        fault=fault.name, expect=fault.expect, outcome=summary.get("outcome", "no report"),
        reason=summary.get("reason", ""), collision=collision,
        goal_reached=summary.get("goal", {}).get("reached"),
        min_clearance=summary.get("min_clearance"), time_to_stop=time_to_stop,
        rejected=node.rejected_since_start, sent=node.sent, orphans=orphans,
        passed=_judge(fault, summary, time_to_stop, orphans), run_dir=str(run_dir),
    )
