"""What a run was expected to do, judged from its scenario and its ground truth.

:func:`annotate` adds to a result row (of :func:`~safe_legged_c3bf.evaluation.runner.
record_from_report`), from the scenario file and the run's ``timeseries.npz`` (the
simulator's /odom: the exact base pose):

* ``impassable``: the ids of the impassable obstacles on the straight path
  (:mod:`.impassable`), '+'-joined ('' when none); ``impassable_by_margin``: those of them
  the bare body would pass (impassable only with the filter's clearance);
* ``stopped_before_impassable``: the robot stopped before the first of them, untouched, not
  fallen, held the stop without creeping over the last ``CREEP_WINDOW`` s and the run went
  on to the scenario's end. Such a run is a success although the goal was not reached;
* ``creep``: its forward progress over that window (m);
* ``unsurvivable``, ``unsurvivable_detail``: a mover no controller could have escaped
  (:mod:`.unsurvivable`); collisions in such runs are counted in their own column;
* ``leaders``: the slower movers ahead on the path going the robot's way, '+'-joined ('' when
  none), and ``overtook``: the robot got past every one of them (:mod:`.overtaking`; None
  without leaders or ground truth).

The outcome is classified again afterwards (``stopped_impassable`` instead of
``goal_not_reached``). Rows without a readable scenario or time series keep None.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from safe_legged_c3bf.evaluation.impassable import held_stop, impassable_obstacles
from safe_legged_c3bf.evaluation.overtaking import leaders, overtaken
from safe_legged_c3bf.evaluation.unsurvivable import unsurvivable_threats

#: The run must have lasted to within this of the scenario's duration (s) to count as held.
END_TOLERANCE = 0.5
#: Fields added by :func:`annotate`.
FIELDS = ("impassable", "impassable_by_margin", "stopped_before_impassable", "creep",
          "unsurvivable", "unsurvivable_detail", "leaders", "overtook")


def read_odom(run_dir: str | Path) -> np.ndarray | None:
    """The ground-truth base rows (t, x, y, z, yaw, ...) of a run folder, or None."""
    try:
        with np.load(Path(run_dir) / "timeseries.npz") as z:
            odom = np.asarray(z["odom"], dtype=float)
    except (OSError, KeyError, ValueError):
        return None
    return odom if odom.ndim == 2 and odom.shape[1] >= 5 and len(odom) else None


def _load(scenario: str) -> Any:
    """The parsed scenario, or None (e.g. an override the installed filter does not know)."""
    from safe_legged_c3bf.sim.scenario import load_scenario

    try:
        return load_scenario(scenario)
    except (ValueError, OSError):
        return None


def judge(rec: dict[str, Any], scenario: Any, odom: np.ndarray | None) -> dict[str, Any]:
    """The :data:`FIELDS` of a row, given its parsed scenario and ground-truth odom."""
    out: dict[str, Any] = dict.fromkeys(FIELDS)
    if scenario is None:
        return out
    blockers = impassable_obstacles(scenario)
    out["impassable"] = "+".join("+".join(b.ids) for b in blockers)
    out["impassable_by_margin"] = "+".join("+".join(b.ids) for b in blockers if b.by_margin)
    ahead = leaders(scenario)
    out["leaders"] = "+".join(o.id for o in ahead)
    if odom is not None:
        threats = unsurvivable_threats(scenario, odom)
        out["unsurvivable"] = bool(threats)
        out["unsurvivable_detail"] = "; ".join(t.describe() for t in threats)
        if ahead:
            out["overtook"] = len(overtaken(scenario, odom, ahead)) == len(ahead)
    if blockers and odom is not None:
        stop = held_stop(scenario, odom, blockers)
        if stop is not None:
            out["creep"] = stop.creep
            lasted = (rec.get("sim_time") or 0.0) >= scenario.duration - END_TOLERANCE
            out["stopped_before_impassable"] = bool(
                stop.held and lasted and rec.get("collision") is False
                and rec.get("fallen") is False)
        else:
            out["stopped_before_impassable"] = False
    elif not blockers:
        out["stopped_before_impassable"] = False
    return out


def annotate(rec: dict[str, Any], scenario: str, run_dir: str | Path) -> dict[str, Any]:
    """Add the :data:`FIELDS` to ``rec`` (in place) and classify it again; return it."""
    from safe_legged_c3bf.evaluation.runner import classify

    if rec.get("variant") == "free":
        rec.update(dict.fromkeys(FIELDS), stopped_before_impassable=False, impassable="",
                   impassable_by_margin="", leaders="")
        return rec
    try:
        rec.update(judge(rec, _load(scenario), read_odom(run_dir)))
    except Exception as err:  # noqa: BLE001 - a checking bug must not lose the run's row
        rec.update(dict.fromkeys(FIELDS))
        rec["reason"] = f"{rec.get('reason') or ''} (expectation check failed: {err!r})"
    if rec.get("outcome") not in ("startup_failed", "interrupted"):
        outcome, flags = classify(rec)
        rec["outcome"], rec["failures"] = outcome, "+".join(flags)
    return rec
