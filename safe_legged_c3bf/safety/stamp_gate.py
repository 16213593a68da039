"""Judge a message's time stamp against the receiving node's own clock.

A node on sim time that receives a wall-clock stamp (a publisher without ``use_sim_time``),
or a node on wall time that receives a sim-time stamp, sees a stamp decades in the future
or in the past. Neither may be believed: a stamp from the future would make the message
count as fresh forever (and, in a tracker, make every real message look old), a stamp far in
the past describes a world that is gone. :class:`StampGate` accepts a stamp only within
``[now - max_age, now + max_future]`` of the receiver's clock, counts every rejection by
reason, and never moves the receiver's notion of time: the caller keeps using its own clock.

Units: seconds, on the receiving node's clock (sim or wall).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from enum import StrEnum


class StampVerdict(StrEnum):
    """What :meth:`StampGate.check` decided about one stamp."""

    OK = "ok"
    FUTURE = "future_stamp"  # more than max_future ahead of the receiver's clock
    STALE = "stale_stamp"  # more than max_age behind the receiver's clock
    NON_FINITE = "non_finite_stamp"  # NaN or Inf


@dataclass
class StampGate:
    """Accept stamps within ``[now - max_age, now + max_future]`` (s) of the receiver's clock.

    Attributes:
        max_future: how far ahead of the receiver's clock a stamp may be (s, >= 0): the
            clock's own jitter between processes (a /clock message still in flight).
        max_age: how old a stamp may be on arrival (s, > 0).
        counts: rejections so far, keyed by :class:`StampVerdict` value.

    """

    max_future: float
    max_age: float
    counts: Counter = field(default_factory=Counter)

    def __post_init__(self) -> None:
        """Validate the bounds (ValueError naming the bad one)."""
        if not (math.isfinite(self.max_future) and self.max_future >= 0.0):
            raise ValueError(f"max_future must be finite and >= 0, got {self.max_future!r}")
        if not (self.max_age > 0.0 and not math.isnan(self.max_age)):
            raise ValueError(f"max_age must be > 0, got {self.max_age!r}")

    def verdict(self, stamp: float, now: float) -> StampVerdict:
        """The verdict on ``stamp`` at the receiver's time ``now``, without counting it."""
        if not math.isfinite(stamp):
            return StampVerdict.NON_FINITE
        if stamp > now + self.max_future:
            return StampVerdict.FUTURE
        if stamp < now - self.max_age:
            return StampVerdict.STALE
        return StampVerdict.OK

    def check(self, stamp: float, now: float) -> StampVerdict:
        """The verdict on ``stamp`` at ``now``; a rejection is counted."""
        result = self.verdict(stamp, now)
        if result is not StampVerdict.OK:
            self.counts[result.value] += 1
        return result

    @property
    def rejected(self) -> int:
        """Number of stamps rejected so far."""
        return sum(self.counts.values())
