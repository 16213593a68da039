"""Signal and stop child processes by process group: SIGINT first, harder signals on a timer.

Children started with ``start_new_session=True`` lead their own process group, so a signal to
the group reaches everything they started. :func:`stop_groups` is the escalation the bringup's
supervisor (SIGINT, SIGTERM, SIGKILL) and the evaluation runner (SIGINT, SIGKILL) share.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Sequence

POLL_PERIOD = 0.02


def signal_group(pid: int, sig: int) -> bool:
    """Send ``sig`` to the process group led by ``pid``; False if the group is gone."""
    try:
        os.killpg(pid, sig)
        return True
    except (ProcessLookupError, PermissionError):
        return False


def group_alive(proc: subprocess.Popen) -> bool:
    """True while ``proc`` or any other process of its group exists."""
    if proc.poll() is None:
        return True
    return signal_group(proc.pid, 0)


def stop_groups(
    procs: Sequence[subprocess.Popen],
    steps: Sequence[tuple[float, int]],
    wake: bool = False,
) -> list[subprocess.Popen]:
    """SIGINT to the group of each running process, then escalate; return those escalated.

    ``steps`` are (time.monotonic deadline, signal): once a deadline passes, its signal goes
    to the group of every process still running. With ``wake`` a SIGCONT precedes the SIGINT
    (a stopped process must run to handle it).
    """
    for proc in procs:
        if proc.poll() is None:
            if wake:
                signal_group(proc.pid, signal.SIGCONT)
            signal_group(proc.pid, signal.SIGINT)
    escalated: list[subprocess.Popen] = []
    for until, sig in steps:
        while time.monotonic() < until and any(p.poll() is None for p in procs):
            time.sleep(POLL_PERIOD)
        for proc in procs:
            if proc.poll() is None:
                signal_group(proc.pid, sig)
                if proc not in escalated:
                    escalated.append(proc)
    return escalated
