"""Stop a bringup's process group and remove its scratch folders once its task's worker is gone.

``python -m safe_legged_c3bf.evaluation.orphan_guard [--detach] OWNER_PID GROUP_PID [GRACE_S
[DIR ...]]`` watches the process ``OWNER_PID`` (a Ray worker running one evaluation run), the
process group led by ``GROUP_PID`` (that run's bringup, started in its own session) and the
folders ``DIR`` (the task's scratch folders, which the worker removes when the task ends).
If the owner disappears (the worker was killed: its driver died, the task was force-cancelled,
the node is shutting down), a group still running gets the evaluation runner's escalation
(:func:`safe_legged_c3bf.run.process_group.stop_groups`: SIGINT, SIGKILL after ``GRACE_S``,
default 15 s) and the folders are deleted, so neither a bringup nor a scratch folder outlives
its task. The guard exits once the group is gone and the folders are removed.

``--detach`` starts the guard in a new session whose parent exits at once: Ray kills the
children of a worker it kills, and the guard must not be one of them.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from safe_legged_c3bf.run.process_group import signal_group, stop_groups

MODULE = "safe_legged_c3bf.evaluation.orphan_guard"
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
          period: float = POLL_PERIOD, remove: Sequence[str | Path] = ()) -> bool:
    """Watch (see the module docstring); True if the group had to be stopped."""
    target = _Group(group)
    folders = [Path(f) for f in remove]
    while target.poll() is None or any(f.exists() for f in folders):
        if not process_alive(owner):
            stopped = target.poll() is None
            if stopped:
                stop_groups([target], [(time.monotonic() + grace, signal.SIGKILL)])
                deadline = time.monotonic() + 5.0  # SIGKILLed processes take a moment
                while target.poll() is None and time.monotonic() < deadline:
                    time.sleep(0.05)
            for folder in folders:
                shutil.rmtree(folder, ignore_errors=True)
            return stopped
        time.sleep(period)
    return False


def _spawn(args: Sequence[str]) -> subprocess.Popen:
    """``python -m <this module> ARGS`` in a new session, without inherited stdio."""
    return subprocess.Popen([sys.executable, "-m", MODULE, *args], stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)


def detach(args: Sequence[str]) -> subprocess.Popen:
    """Start a guard with ``args`` that is no child of this process.

    Returns the short-lived intermediate process (wait for it: it exits once the guard runs).
    """
    return _spawn(["--detach", *args])


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point: 0 when the group ended by itself, 1 if it was stopped."""
    args = list(sys.argv[1:] if argv is None else argv)
    if args[:1] == ["--detach"]:  # re-start in a new session and leave it behind
        _spawn(args[1:])
        return 0
    try:
        owner, group = int(args[0]), int(args[1])
        grace = float(args[2]) if len(args) > 2 else DEFAULT_GRACE
    except (IndexError, ValueError):
        print("usage: python -m safe_legged_c3bf.evaluation.orphan_guard [--detach] OWNER_PID "
              "GROUP_PID [GRACE_S [DIR ...]]", file=sys.stderr)
        return 2
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C on the terminal is not for us
    return 1 if guard(owner, group, grace, remove=args[3:]) else 0


if __name__ == "__main__":
    raise SystemExit(main())
