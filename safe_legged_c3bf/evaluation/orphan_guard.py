"""Stop a bringup's process group once the process that started it is gone.

``python -m safe_legged_c3bf.evaluation.orphan_guard OWNER_PID GROUP_PID [GRACE_S]`` watches
the process ``OWNER_PID`` (a Ray worker running one evaluation run) and the process group led
by ``GROUP_PID`` (that run's bringup, started in its own session). If the owner disappears
while the group still exists (the worker was killed: its driver died, the task was
force-cancelled, the node is shutting down), the group gets the evaluation runner's escalation
(:func:`safe_legged_c3bf.run.process_group.stop_groups`: SIGINT, SIGKILL after ``GRACE_S``,
default 15 s), so no bringup outlives its task. The guard exits as soon as the group is gone.
It runs in its own session, so killing the worker does not kill the guard.
"""

from __future__ import annotations

import signal
import sys
import time
from pathlib import Path

from safe_legged_c3bf.run.process_group import signal_group, stop_groups

#: Seconds between two looks at the owner and the group.
POLL_PERIOD = 0.5
DEFAULT_GRACE = 15.0


def _stat(pid: int | str) -> list[str] | None:
    """The fields of /proc/<pid>/stat after the command name (state, ppid, pgrp, ...)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()
    except OSError:
        return None


def process_alive(pid: int) -> bool:
    """True while process ``pid`` exists and is not a zombie."""
    fields = _stat(pid)
    return fields is not None and fields[0] not in ("Z", "X")


def group_alive(pgid: int) -> bool:
    """True while a process of group ``pgid`` runs (zombies waiting for a parent do not)."""
    if not Path("/proc/self/stat").exists():
        return signal_group(pgid, 0)
    if not signal_group(pgid, 0):
        return False
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            fields = _stat(entry.name)
            if fields and len(fields) > 2 and fields[2] == str(pgid) and fields[0] not in "ZX":
                return True
    return False


class _Group:
    """A process group seen through the part of Popen that stop_groups uses."""

    def __init__(self, pgid: int) -> None:
        self.pid = pgid

    def poll(self) -> int | None:
        return None if group_alive(self.pid) else 0


def guard(owner: int, group: int, grace: float = DEFAULT_GRACE,
          period: float = POLL_PERIOD) -> bool:
    """Watch until the group is gone; True if it had to be stopped (its owner died first)."""
    target = _Group(group)
    while target.poll() is None:
        if not process_alive(owner):
            stop_groups([target], [(time.monotonic() + grace, signal.SIGKILL)])
            return True
        time.sleep(period)
    return False


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point: 0 when the group ended by itself, 1 if it was stopped."""
    args = sys.argv[1:] if argv is None else argv
    try:
        owner, group = int(args[0]), int(args[1])
        grace = float(args[2]) if len(args) > 2 else DEFAULT_GRACE
    except (IndexError, ValueError):
        print("usage: python -m safe_legged_c3bf.evaluation.orphan_guard OWNER_PID GROUP_PID "
              "[GRACE_S]", file=sys.stderr)
        return 2
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C on the terminal is not for us
    return 1 if guard(owner, group, grace) else 0


if __name__ == "__main__":
    raise SystemExit(main())
