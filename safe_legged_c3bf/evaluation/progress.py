"""The progress line of a campaign: counts, rates so far and an ETA.

:class:`Progress` is told about every finished run (:meth:`Progress.add`) and returns one line
such as::

    evaluate: 37/200 done (12 this session, 1 run failure); filter on: collision 0/20
    (< 13.9 %), success 18/20; filter off: collision 15/17; 1.6 min/run, ETA 4 h 20 min
    (at 18:05)

Rates count obstacle runs with a result (run failures excluded), as the tables do; the bound
after a collision count is its one-sided 95 % upper bound (:mod:`.stats`). The pace is the
wall time of this session divided by the runs it finished (so it includes the parallelism);
the ETA is that pace times the runs left. Times in s unless named otherwise.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from datetime import datetime, timedelta
from typing import Any

from safe_legged_c3bf.evaluation import stats
from safe_legged_c3bf.evaluation.metrics import is_success
from safe_legged_c3bf.evaluation.runner import RUN_FAILURES


class Progress:
    """Counts of a campaign of ``total`` runs, ``finished`` of which were done before.

    Args:
        total: runs in the campaign.
        finished: rows of the runs finished before this session (a resumed campaign).
        clock: monotonic clock (s; for tests).

    """

    def __init__(self, total: int, finished: Iterable[dict[str, Any]] = (),
                 clock: Callable[[], float] = time.monotonic) -> None:
        """Start counting now."""
        self.total = int(total)
        self.rows: list[dict[str, Any]] = list(finished)
        self.session = 0
        self._clock = clock
        self._t0 = clock()

    def add(self, rec: dict[str, Any]) -> str:
        """Count one finished run; return the progress line."""
        self.rows.append(rec)
        self.session += 1
        return self.line()

    def eta(self) -> float | None:
        """Wall seconds until every run is done at this session's pace (None: no pace yet)."""
        left = self.total - len(self.rows)
        if left <= 0:
            return 0.0
        if self.session == 0:
            return None
        return left * (self._clock() - self._t0) / self.session

    def line(self) -> str:
        """The progress line (see the module docstring)."""
        failures = sum(1 for r in self.rows if r.get("outcome") in RUN_FAILURES)
        parts = [f"evaluate: {len(self.rows)}/{self.total} done ({self.session} this session"
                 + (f", {failures} run failure{'s' if failures != 1 else ''})" if failures
                    else ")")]
        for filt in ("on", "off"):
            text = self._rates(filt)
            if text:
                parts.append(f"filter {filt}: {text}")
        parts.append(self._timing())
        return "; ".join(p for p in parts if p)

    def _rates(self, filt: str) -> str:
        """'collision k/n (< bound), success k/n' of the valid obstacle runs of ``filt``."""
        rows = [r for r in self.rows if r.get("filter") == filt
                and r.get("variant", "obstacles") != "free"
                and r.get("outcome") not in RUN_FAILURES]
        if not rows:
            return ""
        n = len(rows)
        k = sum(1 for r in rows if r.get("collision"))
        bound = stats.upper_bound(k, n)
        text = f"collision {k}/{n}" + (f" (< {100 * bound:.1f} %)" if k < n else "")
        if filt == "on":
            text += f", success {sum(1 for r in rows if is_success(r))}/{n}"
        return text

    def _timing(self) -> str:
        """'1.6 min/run, ETA 4 h 20 min (at 18:05)', or '' before the first run ends."""
        if self.session == 0:
            return ""
        pace = (self._clock() - self._t0) / self.session
        eta = self.eta() or 0.0
        if len(self.rows) >= self.total:
            return f"{pace / 60:.1f} min/run, all done"
        at = (datetime.now() + timedelta(seconds=eta)).strftime("%H:%M")
        return f"{pace / 60:.1f} min/run, ETA {duration_text(eta)} (at {at})"


def duration_text(seconds: float) -> str:
    """'45 s', '12 min', '4 h 20 min' or '3 d 2 h'."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    minutes = s // 60
    if minutes < 60:
        return f"{minutes} min"
    hours, minutes = divmod(minutes, 60)
    if hours < 48:
        return f"{hours} h {minutes} min"
    days, hours = divmod(hours, 24)
    return f"{days} d {hours} h"
