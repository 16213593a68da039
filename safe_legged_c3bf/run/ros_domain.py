"""Allocate ROS_DOMAIN_IDs that no other run on this machine is using, on localhost only.

Each allocation holds an exclusive ``flock`` on a lock file for as long as the returned
object lives (or the process runs), so concurrent test sessions and parallel evaluation jobs
never hear each other. Domain ids 1..100 are used (valid for Fast DDS; 0 is left to users).

:func:`restrict_to_localhost` keeps discovery on this host the way
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` does, but over UDP without Fast DDS's shared
memory transport, whose port health check stalls a publisher for 333 ms
(``config/dds/localhost_udp.xml`` says why).
"""

from __future__ import annotations

import fcntl
import os
import random
import tempfile
from pathlib import Path

_LOCK_DIR = Path(tempfile.gettempdir()) / "safe_legged_c3bf_domains"
DOMAIN_RANGE = range(1, 101)
PROFILE_VARIABLE = "FASTRTPS_DEFAULT_PROFILES_FILE"  # the name Fast DDS 2.x reads
_FAST_DDS_RMW = "rmw_fastrtps_cpp"


def localhost_profile() -> Path | None:
    """The project's Fast DDS profile (UDP, unicast discovery on 127.0.0.1), if installed."""
    from safe_legged_c3bf.run.config import config_path

    try:
        path = config_path("dds", "localhost_udp.xml")
    except FileNotFoundError:
        return None
    return path if path.is_file() else None


def restrict_to_localhost(env: dict[str, str] | os._Environ) -> None:
    """Set ``env`` so that ROS 2 discovers participants on this host only.

    With Fast DDS and no profile of the user's own: the project's profile and
    ``ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT`` (the rmw then leaves the profile's
    transports alone). Otherwise (another rmw, a user's ``FASTRTPS_DEFAULT_PROFILES_FILE``,
    the profile not installed): ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``.
    """
    env.pop("ROS_LOCALHOST_ONLY", None)
    profile = localhost_profile()
    fast_dds = env.get("RMW_IMPLEMENTATION", _FAST_DDS_RMW) == _FAST_DDS_RMW
    users_profile = bool(env.get(PROFILE_VARIABLE)) and not _names_profile(env, profile)
    if profile is None or not fast_dds or users_profile:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        return
    env[PROFILE_VARIABLE] = str(profile)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"


def is_localhost_only(env: dict[str, str] | os._Environ) -> bool:
    """Whether ``env`` restricts discovery to this host (either way above)."""
    if env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST":
        return True
    return (env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "SYSTEM_DEFAULT"
            and _names_profile(env, localhost_profile()))


def _names_profile(env: dict[str, str] | os._Environ, profile: Path | None) -> bool:
    """Whether ``env``'s Fast DDS profile variable names the project's ``profile``."""
    own = env.get(PROFILE_VARIABLE)
    return profile is not None and bool(own) and Path(own) == profile


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
    restrict_to_localhost(target)
    return dict(target), lease
