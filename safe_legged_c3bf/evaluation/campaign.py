"""Run the planned runs of an evaluation, continuing whatever its output folder already holds.

:func:`run_campaign` takes the run specs of an evaluation and a pool (the local
:class:`~safe_legged_c3bf.evaluation.runner.Runner` or the
:class:`~safe_legged_c3bf.evaluation.ray_pool.RayPool`), skips the runs the folder already
finished (:class:`~safe_legged_c3bf.evaluation.campaign_state.CampaignState`), runs the rest
and, as each run ends, saves its ``row.json``, rewrites ``results.csv`` (atomically) and prints
the progress line (:mod:`.progress`). Ctrl-C or SIGTERM stops the runs; every row written
before stays, so running the same command again continues the campaign.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from safe_legged_c3bf.evaluation.campaign_state import ROW_FILE, CampaignState
from safe_legged_c3bf.evaluation.metrics import attach_overhead
from safe_legged_c3bf.evaluation.progress import Progress
from safe_legged_c3bf.evaluation.results import RUN_COLUMNS, write_csv
from safe_legged_c3bf.evaluation.runner import RunSpec


class Pool(Protocol):
    """What a campaign needs of a pool (Runner, RayPool)."""

    def run(self, specs: Sequence[RunSpec], durations: dict[str, float] | None = None,
            on_result: Callable[[dict[str, Any]], None] | None = None,
            ) -> list[dict[str, Any]]:
        """Run ``specs``, calling ``on_result`` with each row as its run ends."""


@dataclass
class CampaignResult:
    """What a campaign session did.

    Attributes:
        records: rows of every finished run (earlier sessions' and this one's), in plan order.
        interrupted: the session was stopped (Ctrl-C, SIGTERM).
        wall: wall seconds of this session's runs.
        resumed: runs finished by earlier sessions.
        ran: runs this session finished.

    """

    records: list[dict[str, Any]]
    interrupted: bool
    wall: float
    resumed: int
    ran: int


def _sigterm(signum: int, frame) -> None:  # noqa: ANN001
    raise KeyboardInterrupt


def run_campaign(
    specs: Sequence[RunSpec],
    durations: dict[str, float],
    pool: Pool,
    state: CampaignState,
    restart: bool = False,
    say: Callable[[str], None] | None = None,
) -> CampaignResult:
    """Run what is left of ``specs`` on ``pool``; see the module docstring.

    ``restart`` forgets the finished runs of the folder first (they are run again). Raises
    CampaignMismatchError if the folder holds finished runs of a different campaign.
    """
    say = say or (lambda line: print(line, flush=True))
    if restart:
        forget(state, specs)
    finished, todo = state.split(specs)
    if finished:
        say(f"evaluate: continuing {state.out}: {len(finished)} of {len(specs)} run(s) "
            f"already finished, {len(todo)} to run")
    progress = Progress(len(specs), finished)
    by_id = {s.run_id: s for s in specs}
    done = list(finished)

    def on_result(rec: dict[str, Any]) -> None:
        state.record(by_id[rec["run_id"]], rec)  # first: a kill now loses nothing
        done.append(rec)
        write_rows(state.out / "results.csv", done)
        say(progress.add(rec))

    previous = signal.signal(signal.SIGTERM, _sigterm)
    t0 = time.monotonic()
    interrupted = False
    try:
        if todo:
            pool.run(todo, durations, on_result=on_result)
    except KeyboardInterrupt:
        interrupted = True
        say("evaluate: interrupted; the finished runs are kept (run the same command to "
            "continue)")
    finally:
        signal.signal(signal.SIGTERM, previous)
    order = {s.run_id: i for i, s in enumerate(specs)}
    records = sorted(done, key=lambda r: order.get(r["run_id"], len(order)))
    return CampaignResult(records, interrupted, time.monotonic() - t0, len(finished),
                          progress.session)


def forget(state: CampaignState, specs: Sequence[RunSpec]) -> None:
    """Remove the saved rows of ``specs`` (and the folder's results.csv): run them again."""
    for spec in specs:
        (state.run_dir(spec.run_id) / ROW_FILE).unlink(missing_ok=True)
    (state.out / "results.csv").unlink(missing_ok=True)


def write_rows(path: Path, rows: list[dict[str, Any]]) -> None:
    """Write results.csv atomically (a temporary file renamed over it)."""
    tmp = path.with_name(f".{path.name}.tmp")
    write_csv(tmp, attach_overhead([dict(r) for r in rows]), RUN_COLUMNS)
    os.replace(tmp, path)
