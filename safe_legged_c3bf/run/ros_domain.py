"""Allocate ROS_DOMAIN_IDs that no other run on this machine is using.

Each allocation holds an exclusive ``flock`` on a lock file for as long as the returned
object lives (or the process runs), so concurrent test sessions and parallel evaluation jobs
never hear each other. Domain ids 1..100 are used (valid for Fast DDS; 0 is left to users).
"""

from __future__ import annotations

import fcntl
import os
import random
import tempfile
from pathlib import Path

_LOCK_DIR = Path(tempfile.gettempdir()) / "safe_legged_c3bf_domains"
DOMAIN_RANGE = range(1, 101)


class DomainLease:
    """A ROS domain id held exclusively until :meth:`release` (or process exit)."""

    def __init__(self, domain_id: int, handle) -> None:  # noqa: ANN001 - open file object
        self.domain_id = domain_id
        self._handle = handle

    def release(self) -> None:
        """Give the domain id back."""
        if self._handle is not None:
            fcntl.flock(self._handle, fcntl.LOCK_UN)
            self._handle.close()
            self._handle = None


def lease_domain(preferred: int | None = None) -> DomainLease:
    """Lease a free domain id (``preferred`` first if given); raise RuntimeError if none."""
    _LOCK_DIR.mkdir(parents=True, exist_ok=True)
    ids = list(DOMAIN_RANGE)
    random.shuffle(ids)
    if preferred is not None:
        ids.insert(0, preferred)
    for domain_id in ids:
        handle = open(_LOCK_DIR / f"{domain_id}.lock", "w")  # noqa: SIM115 - held open
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        return DomainLease(domain_id, handle)
    raise RuntimeError("no free ROS domain id on this machine")


def isolate_environment(env: dict[str, str] | None = None) -> tuple[dict[str, str], DomainLease]:
    """Return (environment, lease) with a private ROS domain on localhost only.

    With ``env=None`` this process's ``os.environ`` is updated in place.
    """
    lease = lease_domain()
    target = os.environ if env is None else env
    target["ROS_DOMAIN_ID"] = str(lease.domain_id)
    target["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    target.pop("ROS_LOCALHOST_ONLY", None)
    return dict(target), lease
