"""The bringup's terminal: the progress line, its messages and stop requests by signal.

C-level stderr (node logs) is redirected by :mod:`.quiet_stderr`.
"""

from __future__ import annotations

import math
import signal
import sys
import time

PROGRESS_PERIOD_TTY = 0.25
PROGRESS_PERIOD_LOG = 5.0


class Progress:
    """The live progress line: rewritten in place on a TTY, one line every few s otherwise."""

    def __init__(self, stream=None, period: float | None = None) -> None:  # noqa: ANN001
        """Write to ``stream`` (default stdout) every ``period`` s (default by stream kind)."""
        self.stream = stream or sys.stdout
        self.tty = self.stream.isatty()
        default = PROGRESS_PERIOD_TTY if self.tty else PROGRESS_PERIOD_LOG
        self.period = default if period is None else max(float(period), 0.05)
        self._last = -math.inf
        self._width = 0

    def update(self, text: str, force: bool = False) -> None:
        """Show ``text`` if the period has passed (or ``force``)."""
        now = time.monotonic()
        if not force and now - self._last < self.period:
            return
        self._last = now
        if self.tty:
            pad = max(self._width - len(text), 0)
            self.stream.write("\r" + text + " " * pad)
            self._width = len(text)
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def clear(self) -> None:
        """End the rewritten line before other output."""
        if self.tty and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self.stream.flush()
            self._width = 0


def progress_text(monitor, duration: float) -> str:  # noqa: ANN001
    """'t 12.3/40.0 s | RTF 0.97 | goal 3.21 m | filter ACTIVE'."""
    t = monitor.sim_time
    rtf = monitor.real_time_factor()
    dist = monitor.distance_to_goal()
    parts = [
        "t   -.-" if t is None else f"t {t:5.1f}/{duration:.1f} s",
        "RTF  -.--" if rtf is None else f"RTF {rtf:5.2f}",
        "goal   -.-- m" if dist is None else f"goal {dist:5.2f} m",
        f"filter {monitor.status_text}",
    ]
    safety = monitor.data.safety
    if safety and safety[-1][2] > 0:
        parts.append(f"COLLISIONS {int(safety[-1][2])}")
    return " | ".join(parts)


def say(progress: Progress | None, text: str) -> None:
    """Print ``bringup: text`` to stderr (ending the progress line first)."""
    if progress is not None:
        progress.clear()
    print(f"bringup: {text}", file=sys.stderr, flush=True)


class StopRequest:
    """Records SIGINT / SIGTERM / SIGHUP instead of raising, so that stopping is orderly."""

    def __init__(self) -> None:
        """Install the handlers (main thread only)."""
        self.signum: int | None = None
        self._previous = {}
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            self._previous[sig] = signal.signal(sig, self._handler)

    def _handler(self, signum: int, frame) -> None:  # noqa: ANN001
        if self.signum is None:
            self.signum = signum

    def __bool__(self) -> bool:
        return self.signum is not None

    def restore(self) -> None:
        """Put the previous handlers back."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
