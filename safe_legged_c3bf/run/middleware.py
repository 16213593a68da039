"""DDS settings the graph's processes share, set in the environment before rclpy starts.

Asynchronous publishing (``RMW_FASTRTPS_PUBLICATION_MODE=ASYNCHRONOUS``): with rmw_fastrtps'
default synchronous mode a ``publish()`` sends from the caller's thread and can block it.
Measured here: right after physics starts, a node's publish blocked for 333-342 ms in about one
run in three (A1, whole body, paced by the wall clock, 4 of 12 short runs), so the gait
controller answered no state for a third of a second, the motor drivers damped and robots
fell; with asynchronous publishing 0 of 12. A value the user set is kept (other middlewares
ignore the variable).
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping

PUBLICATION_MODE = "RMW_FASTRTPS_PUBLICATION_MODE"


def use_asynchronous_publishing(env: MutableMapping[str, str] | None = None) -> str:
    """Set asynchronous publishing in ``env`` (default: this process's) unless set; the mode."""
    target = os.environ if env is None else env
    return target.setdefault(PUBLICATION_MODE, "ASYNCHRONOUS")
