"""CPU time of the graph's processes, per node: what a run costs without a profiler.

Linux only (``/proc/<pid>/stat``); elsewhere the figures are simply missing. A process's CPU
time is user + system time of the process and of its reaped children, in core-seconds.
A node process may exit before the run is reported (the simulator ends itself), so the
meter keeps the last value it read for each node: sample it often (the launcher does at
every check, ten times a second).
"""

from __future__ import annotations

import os
import resource
from collections.abc import Mapping
from pathlib import Path

#: Clock ticks per second of /proc/<pid>/stat's time fields.
_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def process_cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of ``pid`` and its waited-for children; None if unreadable."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # the command name (field 2) may hold spaces and parentheses: split after its last ')'
    fields = text[text.rfind(")") + 2:].split()
    try:
        utime, stime, cutime, cstime = (int(v) for v in fields[11:15])
    except (ValueError, IndexError):
        return None
    return (utime + stime + cutime + cstime) / _TICKS


def own_cpu_seconds() -> float:
    """User + system CPU seconds of this process (all its threads)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


class CpuMeter:
    """The last CPU time read of each named process (core-seconds since it started)."""

    def __init__(self) -> None:
        """An empty meter."""
        self.seconds: dict[str, float] = {}

    def sample(self, pids: Mapping[str, int]) -> None:
        """Read every process of ``pids`` (name -> pid); an exited one keeps its last value."""
        for name, pid in pids.items():
            value = process_cpu_seconds(pid)
            if value is not None:
                self.seconds[name] = max(value, self.seconds.get(name, 0.0))


def cpu_summary(seconds: Mapping[str, float], sim_time: float | None, wall_time: float) -> dict:
    """Per node and in total: core-seconds per sim second, and cores used over the wall time.

    Returns ``{"per_sim_second": {node: x}, "total_per_sim_second": x, "cores": x,
    "seconds": {node: core-s}}``; the figures are None without sim time or measurements.
    """
    total = float(sum(seconds.values()))
    sim = sim_time if sim_time is not None and sim_time > 0 and seconds else None
    return {
        "seconds": {k: round(float(v), 3) for k, v in sorted(seconds.items())},
        "per_sim_second": {
            k: (round(float(v) / sim, 3) if sim else None) for k, v in sorted(seconds.items())
        },
        "total_per_sim_second": round(total / sim, 3) if sim else None,
        "cores": round(total / wall_time, 3) if wall_time > 0 and seconds else None,
    }
