"""Redirect C-level prints to file descriptor 2: to /dev/null or to a log file.

pybullet prints its build time on import and rcutils writes node logs to fd 2; both bypass
``sys.stderr``. :class:`StderrRedirect` is the one implementation: :func:`quiet_stderr`
silences fd 2 for a block, :func:`stderr_to_file` sends it to a file for a whole run while
Python's ``sys.stderr`` keeps the terminal.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path


class StderrRedirect:
    """Point fd 2 at ``target`` until :meth:`restore` (also a context manager).

    With ``keep_python_stderr`` Python's ``sys.stderr`` goes on writing to the original fd 2
    (the terminal) while C code writes to ``target``; otherwise both go to ``target``.
    """

    def __init__(self, target: str | os.PathLike[str], keep_python_stderr: bool = False) -> None:
        """Start redirecting (``target`` is appended to; its folder is created)."""
        target = Path(target)
        if str(target) != os.devnull:
            target.parent.mkdir(parents=True, exist_ok=True)
        sys.stderr.flush()
        self._saved_fd = os.dup(2)
        self._saved_stream = None
        if keep_python_stderr:
            self._saved_stream = sys.stderr
            sys.stderr = open(  # noqa: SIM115 - closed in restore()
                os.dup(self._saved_fd), "w", buffering=1, encoding="utf-8", errors="replace"
            )
        with open(target, "ab") as sink:
            os.dup2(sink.fileno(), 2)

    def restore(self) -> None:
        """Put fd 2 (and ``sys.stderr``) back; a second call does nothing."""
        if self._saved_fd < 0:
            return
        sys.stderr.flush()
        os.dup2(self._saved_fd, 2)
        os.close(self._saved_fd)
        self._saved_fd = -1
        if self._saved_stream is not None:
            sys.stderr.close()
            sys.stderr = self._saved_stream
            self._saved_stream = None

    def __enter__(self) -> StderrRedirect:
        return self

    def __exit__(self, *exc: object) -> None:
        self.restore()


def quiet_stderr() -> StderrRedirect:
    """Redirect fd 2 to /dev/null for the duration of a ``with`` block, then restore it."""
    return StderrRedirect(os.devnull)


def stderr_to_file(path: Path) -> StderrRedirect:
    """Send fd 2 (rcutils node logs) to ``path``; Python's sys.stderr keeps the terminal."""
    return StderrRedirect(path, keep_python_stderr=True)
