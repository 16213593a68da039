"""The on-disk state of a campaign: which runs of an output folder are finished, for resuming.

Every finished run leaves ``<out>/runs/<run_id>/row.json``: its result row and the
fingerprint of what ran (the run's spec, a SHA-256 of its scenario file and the settings that
change a run: ``in_process``, ``full_duration``). The file is written atomically (a temporary
file renamed over it) as soon as the run ends, so a killed driver loses no finished run.

:meth:`CampaignState.split` divides the planned runs of an evaluation into those already
finished in the folder (their rows are reused) and those still to run. A run counts as
finished when its row is there and its outcome is a result; rows of runs that were
``interrupted`` (the evaluation stopped them) or ``startup_failed`` (nothing ran) are run
again. A finished run whose fingerprint differs from the planned one (other options, an edited
scenario, another generator version) is a :class:`CampaignMismatchError`: the folder holds another
campaign, and mixing the two would make the rates meaningless.

Folders written before ``row.json`` existed (no run folder has one) are continued from their
``results.csv`` (the rows whose run id, filter, variant and seed match the plan; the scenario
column is the scenario's name, which need not be its file's).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from safe_legged_c3bf.evaluation.runner import RunSpec

ROW_FILE = "row.json"
#: Outcomes that are not results: such runs are run again when a campaign is resumed.
RERUN_OUTCOMES = frozenset({"interrupted", "startup_failed"})
#: results.csv columns that must match the plan to reuse a row without a row.json.
_LEGACY_KEYS = ("filter", "variant", "seed")


class CampaignMismatchError(ValueError):
    """The output folder holds finished runs of a different campaign."""


def scenario_digest(scenario: str) -> str | None:
    """SHA-256 (hex) of the scenario file of ``scenario`` (name or path); None if unreadable."""
    from safe_legged_c3bf.sim.scenario import ScenarioError, resolve_scenario

    try:
        return hashlib.sha256(resolve_scenario(scenario).read_bytes()).hexdigest()
    except (ScenarioError, OSError):
        return None


def fingerprint(spec: RunSpec, settings: dict[str, Any]) -> dict[str, Any]:
    """What must be equal for a finished run to stand for a planned one (JSON types)."""
    data = asdict(spec)
    data["extra_args"] = list(spec.extra_args)
    data["scenario"] = _stem(spec.scenario)  # the folder may have moved: compare by name ...
    data["scenario_sha256"] = scenario_digest(spec.scenario)  # ... and by content
    return {"spec": data, "settings": dict(sorted(settings.items()))}


def _stem(scenario: str) -> str:
    return Path(scenario).stem if scenario.endswith((".yaml", ".yml")) else scenario


def write_row(run_dir: Path, rec: dict[str, Any], print_: dict[str, Any]) -> Path:
    """Write ``row.json`` (the row and its fingerprint) into ``run_dir`` atomically."""
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / ROW_FILE
    fd, tmp = tempfile.mkstemp(prefix=".row-", suffix=".json", dir=run_dir)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump({"fingerprint": print_, "row": rec}, f, indent=1, default=str)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def read_row(run_dir: Path) -> dict[str, Any] | None:
    """The content of ``run_dir/row.json`` ({'fingerprint', 'row'}), or None if unusable."""
    try:
        with open(run_dir / ROW_FILE, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError):
        return None
    ok = isinstance(data, dict) and isinstance(data.get("row"), dict) and isinstance(
        data.get("fingerprint"), dict)
    return data if ok else None


class CampaignState:
    """The finished runs of the evaluation folder ``out`` (see the module docstring).

    Args:
        out: the evaluation folder (run folders in ``out/runs/<run_id>``).
        settings: the options that change every run (``in_process``, ``full_duration``).

    """

    def __init__(self, out: Path, settings: dict[str, Any]) -> None:
        """Look at ``out`` (which need not exist yet)."""
        self.out = Path(out)
        self.settings = dict(settings)
        self._prints: dict[str, dict[str, Any]] = {}

    def run_dir(self, run_id: str) -> Path:
        """The run folder of ``run_id``."""
        return self.out / "runs" / run_id

    def split(self, specs: Sequence[RunSpec]) -> tuple[list[dict[str, Any]], list[RunSpec]]:
        """(rows of the finished runs, specs still to run), both in the order of ``specs``.

        Raises CampaignMismatchError if a finished run was made with other settings.
        """
        legacy = self._legacy_rows()
        done: list[dict[str, Any]] = []
        todo: list[RunSpec] = []
        for spec in specs:
            print_ = self.fingerprint(spec)
            saved = read_row(self.run_dir(spec.run_id))
            if saved is not None:
                row = saved["row"]
                if row.get("outcome") in RERUN_OUTCOMES:
                    todo.append(spec)
                    continue
                if saved["fingerprint"] != print_:
                    raise CampaignMismatchError(_mismatch(spec.run_id, saved["fingerprint"], print_,
                                                     self.out))
                done.append(row)
            elif _legacy_match(legacy.get(spec.run_id), spec):
                done.append(legacy[spec.run_id])
            else:
                todo.append(spec)
        return done, todo

    def fingerprint(self, spec: RunSpec) -> dict[str, Any]:
        """The fingerprint of ``spec`` under this campaign's settings (cached)."""
        if spec.run_id not in self._prints:
            self._prints[spec.run_id] = fingerprint(spec, self.settings)
        return self._prints[spec.run_id]

    def record(self, spec: RunSpec, rec: dict[str, Any]) -> Path:
        """Save the row of a finished run (``row.json`` in its run folder)."""
        return write_row(self.run_dir(spec.run_id), rec, self.fingerprint(spec))

    def _legacy_rows(self) -> dict[str, dict[str, Any]]:
        """Rows of ``results.csv`` of a folder written before row.json (none has one)."""
        from safe_legged_c3bf.evaluation.results import read_csv

        path = self.out / "results.csv"
        if not path.is_file() or any((self.out / "runs").glob(f"*/{ROW_FILE}")):
            return {}
        try:
            rows = read_csv(path)
        except (OSError, ValueError):
            return {}
        return {str(r.get("run_id")): r for r in rows}


def _legacy_match(row: dict[str, Any] | None, spec: RunSpec) -> bool:
    """True if a results.csv row (no fingerprint) is a finished run of ``spec``."""
    if row is None or row.get("outcome") in RERUN_OUTCOMES or not row.get("outcome"):
        return False
    planned = {"filter": "on" if spec.filter_enabled else "off", "variant": spec.variant,
               "seed": spec.seed}
    return all(row.get(k) == planned[k] for k in _LEGACY_KEYS)


def _mismatch(run_id: str, old: dict[str, Any], new: dict[str, Any], out: Path) -> str:
    """The message of a CampaignMismatchError: the first field that differs."""
    diffs = [f"{part}.{k}: {old.get(part, {}).get(k)!r} (folder) vs {new[part].get(k)!r} "
             f"(now)" for part in ("spec", "settings")
             for k in sorted(set(old.get(part, {})) | set(new[part]))
             if old.get(part, {}).get(k) != new[part].get(k)]
    return (f"{out} holds a finished run {run_id!r} of a different campaign "
            f"({'; '.join(diffs[:3]) or 'different fingerprint'}): give a new --out, or "
            "--restart to run every run again")
