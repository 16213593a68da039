"""Stop a bringup's process group and remove its scratch folders once its task's worker is gone.

A Ray task starts its guard first, before it creates anything
(:meth:`GuardLink.start`): a detached process that holds the read end of a pipe whose write
end only the task's worker holds. Through the link the task then names what the guard must
clean up if the worker dies: its scratch folders (``dir PATH``) as it creates them and its
bringup's process group (``group PGID``) as it starts it. If the worker dies (its driver was
killed, the task was force-cancelled, the node is shutting down), the kernel closes the write
end; the guard reads end-of-file, gives a group still running the evaluation runner's
escalation (:func:`safe_legged_c3bf.run.process_group.stop_groups`: SIGINT, SIGKILL after the
grace, default 15 s) and deletes the folders. A task that ends normally cleans up itself and
releases the guard (``end``). Nothing the task creates exists before its guard does, so no
moment of a task's life leaves a bringup or a folder behind.

The guard is detached (a new session whose starter exits at once): Ray kills the children
of a worker it kills, and the guard must not be one of them. Its command line, ``python -m
safe_legged_c3bf.evaluation.orphan_guard [--detach] --fd N [GRACE_S]``, is for
:meth:`GuardLink.start`.
"""

from __future__ import annotations

import os
import select
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from safe_legged_c3bf.run.process_group import signal_group, stop_groups

MODULE = "safe_legged_c3bf.evaluation.orphan_guard"
#: Seconds between two looks at the link.
POLL_PERIOD = 0.5
DEFAULT_GRACE = 15.0
#: Seconds the guard keeps retrying to remove a folder something still writes into.
REMOVE_PATIENCE = 10.0


def _stat(pid: int | str) -> list[str] | None:
    """The fields of /proc/<pid>/stat after the command name (state, ppid, pgrp, ...)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()
    except OSError:
        return None


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


class _Watch:
    """What a guard cleans up, as its link has told it, and whether the link ended."""

    def __init__(self, link: int) -> None:
        self.groups: list[_Group] = []
        self.folders: list[Path] = []
        self.link: int | None = link
        self.released = False  # the task ended normally
        self.orphaned = False  # the link's write end closed without a release
        self._partial = b""

    def listen(self, timeout: float) -> None:
        """Wait up to ``timeout`` s for the link and apply what it says."""
        if self.link is None:
            return
        ready, _, _ = select.select([self.link], [], [], timeout)
        if not ready:
            return
        try:
            data = os.read(self.link, 65536)
        except OSError:
            data = b""
        if not data:
            self.orphaned = not self.released
            os.close(self.link)
            self.link = None
            return
        *lines, self._partial = (self._partial + data).split(b"\n")
        for line in lines:
            self._apply(line.decode(errors="replace"))

    def _apply(self, line: str) -> None:
        word, _, value = line.partition(" ")
        if word == "group" and value.strip().isdigit():
            self.groups.append(_Group(int(value)))
        elif word == "dir" and value:
            self.folders.append(Path(value))
        elif word == "end":
            self.released = True


def _clean_up(watch: _Watch, grace: float) -> bool:
    """Stop the watched groups still running, remove the folders; True if a group ran."""
    running = [g for g in watch.groups if g.poll() is None]
    if running:
        stop_groups(running, [(time.monotonic() + grace, signal.SIGKILL)])
        deadline = time.monotonic() + 5.0  # SIGKILLed processes take a moment
        while any(g.poll() is None for g in running) and time.monotonic() < deadline:
            time.sleep(0.05)
    deadline = time.monotonic() + REMOVE_PATIENCE  # a dying process may still write a file
    while True:
        for folder in watch.folders:
            shutil.rmtree(folder, ignore_errors=True)
        if not any(f.exists() for f in watch.folders) or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    return bool(running)


def guard(link: int, grace: float = DEFAULT_GRACE, period: float = POLL_PERIOD) -> bool:
    """Watch the read end ``link`` of a :class:`GuardLink`'s pipe; True if a group was stopped.

    Runs until the link releases it (nothing touched) or closes without a release (the
    worker died: clean up, see the module docstring).
    """
    watch = _Watch(link)
    while not watch.released:
        if watch.orphaned:
            return _clean_up(watch, grace)
        watch.listen(period)
    return False


def _spawn(args: Sequence[str], pass_fds: Sequence[int] = ()) -> subprocess.Popen:
    """``python -m <this module> ARGS`` in a new session, without inherited stdio."""
    return subprocess.Popen([sys.executable, "-m", MODULE, *args], stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True, pass_fds=tuple(pass_fds))


def detach(args: Sequence[str], pass_fds: Sequence[int] = ()) -> subprocess.Popen:
    """Start a guard with ``args`` that is no child of this process.

    Returns the short-lived intermediate process (wait for it: it exits once the guard runs).
    """
    return _spawn(["--detach", *args], pass_fds)


class GuardLink:
    """The task's end of a detached guard's pipe (see the module docstring).

    Start it before creating anything; tell it each folder right after creating it and each
    bringup right after starting it; :meth:`release` it once the task has cleaned up.
    """

    def __init__(self, write_fd: int) -> None:
        self._fd: int | None = write_fd

    @classmethod
    def start(cls, grace: float = DEFAULT_GRACE, timeout: float = 60.0) -> GuardLink:
        """Start a detached guard and return once it runs (OSError if it could not start)."""
        read_fd, write_fd = os.pipe()
        try:
            starter = detach(["--fd", str(read_fd), f"{grace:g}"], pass_fds=[read_fd])
            try:
                code = starter.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                starter.kill()
                raise OSError(f"the orphan guard did not start within {timeout:g} s") from None
            if code != 0:
                raise OSError(f"the orphan guard's starter exited with {code}")
        except BaseException:
            os.close(write_fd)
            raise
        finally:
            os.close(read_fd)
        return cls(write_fd)

    def _say(self, line: str) -> None:
        """Send one line; a guard that is gone (a broken pipe) costs the safety net, not the run."""
        if self._fd is not None:
            try:
                os.write(self._fd, (line + "\n").encode())
            except BrokenPipeError:
                pass

    def remove_on_orphan(self, folder: str | Path) -> None:
        """The guard deletes ``folder`` if this process dies before :meth:`release`."""
        self._say(f"dir {folder}")

    def stop_on_orphan(self, pgid: int) -> None:
        """The guard stops process group ``pgid`` if this process dies before release."""
        self._say(f"group {pgid}")

    def release(self) -> None:
        """The task has cleaned up: the guard exits without touching anything."""
        if self._fd is not None:
            try:
                self._say("end")
            finally:
                os.close(self._fd)
                self._fd = None


USAGE = "usage: python -m safe_legged_c3bf.evaluation.orphan_guard [--detach] --fd N [GRACE_S]"


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point: 0 when nothing had to be stopped, 1 if a group was."""
    args = list(sys.argv[1:] if argv is None else argv)
    detach = args[:1] == ["--detach"]
    rest = args[1:] if detach else args
    try:
        if rest[:1] != ["--fd"] or len(rest) > 3:
            raise ValueError
        link = int(rest[1])
        grace = float(rest[2]) if len(rest) > 2 else DEFAULT_GRACE
    except (IndexError, ValueError):
        print(USAGE, file=sys.stderr)
        return 2
    if detach:  # re-start in a new session and leave it behind
        _spawn(rest, [link])
        return 0
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C on the terminal is not for us
    return 1 if guard(link, grace) else 0


if __name__ == "__main__":
    raise SystemExit(main())
