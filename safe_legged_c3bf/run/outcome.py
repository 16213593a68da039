"""How a run ends: its outcome, the exit codes and the start-up error."""

from __future__ import annotations

import signal
from dataclasses import dataclass, field

EXIT_OK, EXIT_FAILED, EXIT_STARTUP = 0, 1, 2
EXIT_SIGNAL = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGHUP: 129}


class StartupError(RuntimeError):
    """The run could not be started (message is for the user)."""


@dataclass
class Outcome:
    """How the run ended."""

    kind: str = "completed"  # completed | node_died | startup_failed | interrupted | stalled
    reason: str = ""
    exit_code: int = EXIT_OK
    failed_node: str | None = None
    details: list[str] = field(default_factory=list)
