"""Start a node module as a supervised child: ``python -m safe_legged_c3bf.run.child MODULE ...``.

Runs ``MODULE`` as ``__main__`` (exactly as ``python -m MODULE ...`` would) after asking the
kernel to send it SIGTERM when the supervising process dies (``PR_SET_PDEATHSIG``), so that
no node outlives a bringup that was killed with SIGKILL. The supervisor's pid comes in
``SAFE_LEGGED_C3BF_SUPERVISOR_PID``; if the supervisor is already gone the child exits at once.
"""

from __future__ import annotations

import ctypes
import os
import runpy
import signal
import sys

SUPERVISOR_ENV = "SAFE_LEGGED_C3BF_SUPERVISOR_PID"
_PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int = signal.SIGTERM) -> bool:
    """Ask Linux to send ``sig`` to this process when its parent dies (False if unsupported)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def main() -> None:
    """Run the module named in argv[1] with the remaining arguments."""
    if len(sys.argv) < 2:
        sys.exit("usage: python -m safe_legged_c3bf.run.child MODULE [ARGS...]")
    module = sys.argv[1]
    die_with_parent()
    supervisor = os.environ.get(SUPERVISOR_ENV)
    if supervisor and os.getppid() != int(supervisor):
        sys.exit(f"{module}: the supervising process is gone; not starting")
    sys.argv = [module, *sys.argv[2:]]
    runpy.run_module(module, run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
